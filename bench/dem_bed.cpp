// DEM engine throughput: a bed of N disks (radius 0.04–0.075 m, paper §6 box) settling in a box
// under gravity, cundall-rebound law. Prints particle-steps per second and bytes of engine state
// per particle (container capacities). Usage:
//   bench_dem_bed [N=10000] [steps=2000] [skin_factor=0.3] [threads=1] [warmup=steps]
// Timed: `steps` steps after `warmup` steps (a dense, compacting bed needs warmup ≈ 20000).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "demfem/dem/engine.hpp"
#include "demfem/dem/malloc_tuning.hpp"

int main(int argc, char** argv) {
  demfem::dem::keep_freed_memory_for_reuse(); // as the demfem command does
  using namespace demfem::dem;
  const int n = argc > 1 ? std::atoi(argv[1]) : 10000;
  const long steps = argc > 2 ? std::atol(argv[2]) : 2000;
  EngineConfig c;
  c.law = contact::make_law("cundall-rebound", {{"kn", 1.0e7}, {"ks", 3.0e6}});
  c.damping_c = 2.0;
  if (argc > 3) c.skin_factor = std::atof(argv[3]);
  c.threads = argc > 4 ? std::atoi(argv[4]) : 1;
  Engine e(c);
  const int cols = static_cast<int>(std::sqrt(n * 2.0));
  const double a = 0.151, width = cols * a + 0.01;
  e.add_wall({{0, 100}, {0, 0}, {width, 0}, {width, 100}}, "box");
  std::mt19937_64 g(1);
  for (int k = 0; k < n; ++k) {
    const double r = 0.04 + 0.035 * static_cast<double>(g() >> 11) * 0x1.0p-53;
    e.add_particle(0.08 + a * (k % cols), 0.08 + a * (k / cols), r);
  }
  e.set_dt(e.auto_dt());
  const long warmup = argc > 5 ? std::atol(argv[5]) : steps;
  e.run_steps(warmup); // let the bed form contacts
  const auto t0 = std::chrono::steady_clock::now();
  const double rb0 = e.stats().rebuild_seconds, fc0 = e.stats().force_seconds;
  const long long nr0 = e.stats().neighbour_rebuilds;
  e.run_steps(steps);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto& st = e.stats();
  std::printf("N = %d, %d thread(s), %ld steps in %.3f s: %.3g particle-steps/s; neighbour "
              "entries/particle %.2f, rebuilds %lld, reorders %lld%s\n",
              n, e.threads_in_use(), steps, s, n * static_cast<double>(steps) / s,
              static_cast<double>(st.pair_entries) / n, st.neighbour_rebuilds, st.reorders,
              e.failed() ? (" FAILED: " + e.failure()).c_str() : "");
  std::printf("timed block: %lld rebuilds taking %.3f s (check + rebuild), forces %.3f s\n",
              st.neighbour_rebuilds - nr0, st.rebuild_seconds - rb0, st.force_seconds - fc0);
  const auto m = e.memory_use();
  const double dn = n;
  std::printf(
      "bytes/particle: %.1f total = particles %.1f + contact history %.1f + neighbour "
      "lists (incl. Verlet reference) %.1f + grid %.1f + other (thread buffers, walls) %.1f\n",
      static_cast<double>(m.total()) / dn, static_cast<double>(m.particles) / dn,
      static_cast<double>(m.contact_history) / dn, static_cast<double>(m.neighbour_lists) / dn,
      static_cast<double>(m.grid) / dn, static_cast<double>(m.other) / dn);
}
