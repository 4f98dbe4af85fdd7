// A barrier for the threads of one OpenMP region that runs many time steps (Engine::team_steps).
//
// `#pragma omp barrier` in libgomp ends every barrier with a futex wake system call by the last
// thread to arrive, whether or not a thread sleeps: ≈ 1 µs on this project's virtual machines
// (kernel page-table isolation), three per step with a region per step (the fork, one barrier,
// the join: bench/RESULTS.md). Here the waiting threads spin on a
// generation counter first, as libgomp's do, and only then sleep (std::atomic::wait); the last
// thread's notify makes no system call while nobody sleeps (libstdc++ counts the sleepers).
#pragma once

#include <atomic>
#include <cstdint>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace demfem::dem::detail {

class SpinBarrier {
public:
  // spins: pauses before a waiting thread sleeps (see wait()).
  SpinBarrier(unsigned threads, std::uint32_t spins) : threads_(threads), spins_(spins) {}
  SpinBarrier(const SpinBarrier&) = delete;
  SpinBarrier& operator=(const SpinBarrier&) = delete;

  // Returns once every thread of the team has called it (for this round). Memory: everything a
  // thread wrote before its call is visible to every thread after the call.
  void wait() {
    const std::uint32_t g = generation_.load(std::memory_order_acquire);
    if (arrived_.fetch_add(1, std::memory_order_acq_rel) + 1 == threads_) {
      arrived_.store(0, std::memory_order_relaxed); // before the release below
      generation_.store(g + 1, std::memory_order_release);
      generation_.notify_all();
      return;
    }
    // A step's imbalance is a few µs: spinning through it beats sleeping and being woken; a
    // partner descheduled for longer lets this thread sleep.
    for (std::uint32_t spin = 0; spin < spins_; ++spin) {
      if (generation_.load(std::memory_order_acquire) != g) return;
#if defined(__x86_64__) || defined(__i386__)
      _mm_pause();
#endif
    }
    while (generation_.load(std::memory_order_acquire) == g) generation_.wait(g);
  }

private:
  const unsigned threads_;
  const std::uint32_t spins_;
  alignas(64) std::atomic<unsigned> arrived_{0};
  alignas(64) std::atomic<std::uint32_t> generation_{0};
};

} // namespace demfem::dem::detail
