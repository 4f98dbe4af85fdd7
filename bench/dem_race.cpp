// The demfem side of bench/race-lammps.sh: runs a scene file's DEM model for a fixed number of
// steps the way LAMMPS's timed phase does (no output besides the coordination samples) and
// prints one line in the format of the shared LAMMPS bench's run.sh:
//   demfem N=<n> cores=<c> steps=<s> loop_s=<t> particle_steps_per_s=<x> contacts_per_particle=<z>
// loop_s: wall time of the `steps` steps including the Z samples, after the first neighbour
// build (Engine::prepare), like LAMMPS's "Loop time" after its setup;
// contacts_per_particle: mean coordination number Z = 2 × (particle–particle contacts with
// distance ≤ r_i + r_j) / N, wall contacts excluded, averaged over `zn` samples taken every
// steps/zn steps (LAMMPS: fix ave/time with compute contact/atom).
// Usage: bench_dem_race SCENE [steps=2000] [threads=1] [zn=10] [skin_factor] [adaptive=1]
//        [kernel=simd|avx2|portable|scalar] [order=columns|morton]
// adaptive=1: the adaptive team as `demfem run` has it (probes of the full team only when another
// CPU was idle, and starting on the full team when its CPUs are free at the first step,
// Engine::set_idle_source); adaptive=3: as 1 but always starting on one thread (the engine
// before that start, for comparison); adaptive=2: adaptive, probing without the idle reading;
// adaptive=0: the full team of `threads` always (no adaptive team, EngineConfig::adaptive_threads);
// adaptive=-k: a fixed team of k threads running the `threads` parts.
// Also prints bytes per particle (engine containers) and the rebuild/force split.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/cpu_idle.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/malloc_tuning.hpp"
#include "demfem/scene/load.hpp"

namespace {

// Z from the particle pairs overlapping at the current positions (what LAMMPS's compute
// contact/atom counts; wall contacts excluded).
double coordination(const demfem::dem::Engine& e) {
  return 2.0 * static_cast<double>(e.overlapping_pair_count()) /
         static_cast<double>(e.particles().size());
}

} // namespace

int main(int argc, char** argv) {
  demfem::dem::keep_freed_memory_for_reuse(); // as the demfem command does
  using namespace demfem;
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: bench_dem_race SCENE [steps=2000] [threads=1] [zn=10] [skin] [adaptive=1] "
                 "[kernel=simd|avx2|portable|scalar] [order=columns|morton]\n");
    return 2;
  }
  const long steps = argc > 2 ? std::atol(argv[2]) : 2000;
  const int threads = argc > 3 ? std::atoi(argv[3]) : 1;
  const long zn = argc > 4 ? std::atol(argv[4]) : 10;
  scene::Scene sc;
  try {
    sc = scene::load_scene_file(argv[1], demfem::app::vocabulary()).base;
  } catch (const scene::SceneError& err) {
    std::fprintf(stderr, "%s\n", err.what());
    return 2;
  }
  auto cfg = dem::make_config(sc);
  cfg.threads = threads;
  if (argc > 5 && std::atof(argv[5]) > 0.0) cfg.skin_factor = std::atof(argv[5]);
  const int adaptive = argc > 6 ? std::atoi(argv[6]) : 1;
  cfg.adaptive_threads = adaptive > 0;
  // 7th argument: the pair kernel of cundall-rebound (simd, avx2, portable, scalar; default simd)
  const std::string kernel = argc > 7 ? argv[7] : "simd";
  if (kernel == "portable")
    cfg.pair_kernel = dem::EngineConfig::PairKernel::portable;
  else if (kernel == "avx2")
    cfg.pair_kernel = dem::EngineConfig::PairKernel::avx2;
  else if (kernel == "scalar")
    cfg.pair_kernel = dem::EngineConfig::PairKernel::scalar;
  else if (kernel != "simd") {
    std::fprintf(stderr,
                 "bench_dem_race: kernel must be simd, avx2, portable or scalar, not '%s'\n",
                 kernel.c_str());
    return 2;
  }
  // 8th argument: the particle order of the reorder (EngineConfig::particle_order)
  const std::string order = argc > 8 ? argv[8] : "columns";
  if (order == "morton")
    cfg.particle_order = dem::EngineConfig::ParticleOrder::morton;
  else if (order != "columns") {
    std::fprintf(stderr, "bench_dem_race: order must be columns or morton, not '%s'\n",
                 order.c_str());
    return 2;
  }
  dem::Engine e(cfg);
  e.reserve_particles(sc.soil.dem->particles.size());
  for (const auto& q : sc.soil.dem->particles) e.add_particle(q[0], q[1], q[2], q[3], q[4], q[5]);
  // The scene's copy of the particles is not needed any more (48 B a particle: at 10⁷ disks it
  // was a fifth of the peak memory).
  std::vector<std::array<double, 6>>().swap(sc.soil.dem->particles);
  for (const auto& w : sc.walls) e.add_wall(w);
  e.set_dt(sc.soil.dem->dt > 0.0 ? sc.soil.dem->dt : e.auto_dt());
  if (adaptive < 0) e.set_team(-adaptive); // a fixed team of −adaptive threads
  if (adaptive == 1) e.set_idle_source(dem::idle_cpu_seconds, dem::free_cpus_now);
  if (adaptive == 3) e.set_idle_source(dem::idle_cpu_seconds);
  // The first neighbour build (and, for a large set, the sort into cell order) before the clock,
  // as LAMMPS's setup runs before its "Loop time".
  e.prepare();
  const long every = zn > 0 ? std::max(1L, steps / zn) : steps + 1;
  double zsum = 0.0;
  long nz = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (long s = 0; s < steps && !e.failed();) { // the steps up to the next sample at once
    const long chunk = std::min(steps - s, every - s % every);
    e.run_steps(chunk);
    s += chunk;
    if (zn > 0 && s % every == 0 && !e.failed()) {
      zsum += coordination(e);
      ++nz;
    }
  }
  const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto n = e.particles().size();
  const auto& st = e.stats();
  std::printf("demfem N=%zu cores=%d steps=%ld loop_s=%.3f particle_steps_per_s=%.4g "
              "contacts_per_particle=%.3f\n",
              n, e.threads_in_use(), steps, t, static_cast<double>(n) * steps / t,
              nz > 0 ? zsum / nz : 0.0);
  // A checksum of the final state's bits: equal checksums mean bit-identical runs (kernels).
  std::uint64_t sum = 0;
  for (const auto* v : {&e.particles().x, &e.particles().z, &e.particles().vx, &e.particles().vz,
                        &e.particles().omega})
    for (const double d : *v) {
      std::uint64_t u = 0;
      std::memcpy(&u, &d, sizeof u);
      sum = sum * 1099511628211ull + u;
    }
  std::fprintf(stderr, "# state checksum %016llx\n", static_cast<unsigned long long>(sum));
  const auto m = e.memory_use();
  std::fprintf(stderr,
               "# rebuilds %lld, reorders %lld, pair entries/particle %.2f, rebuild+check %.3f s, "
               "forces%s %.3f s, bytes/particle %.1f (particles %.1f, history %.1f, lists %.1f, "
               "grid %.1f, other %.1f), team steps full/one %lld/%lld (in regions %lld), switches "
               "%lld, probes skipped %lld%s%s\n",
               st.neighbour_rebuilds, st.reorders,
               static_cast<double>(st.pair_entries) / static_cast<double>(n), st.rebuild_seconds,
               e.threads_in_use() > 1 ? " and integration" : "", st.force_seconds,
               static_cast<double>(m.total()) / static_cast<double>(n),
               static_cast<double>(m.particles) / static_cast<double>(n),
               static_cast<double>(m.contact_history) / static_cast<double>(n),
               static_cast<double>(m.neighbour_lists) / static_cast<double>(n),
               static_cast<double>(m.grid) / static_cast<double>(n),
               static_cast<double>(m.other) / static_cast<double>(n), st.team_full_steps,
               st.team_one_steps, st.team_region_steps, st.team_switches, st.team_probes_skipped,
               e.failed() ? " FAILED: " : "", e.failed() ? e.failure().c_str() : "");
  return e.failed() ? 1 : 0;
}
