#include <algorithm>

#include <spdlog/spdlog.h>

#include "hooks.hpp"

namespace demfem::dem::run_detail {

Progress::Progress(const RunOptions& options, double end_time)
    : options_(options), end_time_(end_time) {}

void Progress::report(const Engine& e) {
  if (!options_.progress) return;
  scene::Progress pg;
  pg.stage = "dem";
  pg.time = e.time();
  pg.end_time = end_time_;
  pg.step = e.stats().steps;
  pg.wall_seconds = std::chrono::duration<double>(Clock::now() - start_).count();
  options_.progress(pg);
}

void Progress::tick(const Engine& e) {
  if ((e.stats().steps & 255) == 0 &&
      std::chrono::duration<double>(Clock::now() - last_).count() > 0.5) {
    last_ = Clock::now();
    report(e);
  }
}

void log_statistics(const Engine& e, double solver) {
  if (const auto& st = e.stats(); st.steps > 0) {
    spdlog::info("DEM steps: {}, {} neighbour rebuilds (one per {:.0f} steps), {:.2f} list "
                 "entries per particle; forces{} {:.1f} s, neighbour rebuilds {:.1f} s of {:.1f} s",
                 st.steps, st.neighbour_rebuilds,
                 static_cast<double>(st.steps) /
                     static_cast<double>(std::max<long long>(1, st.neighbour_rebuilds)),
                 static_cast<double>(st.pair_entries) /
                     static_cast<double>(std::max<std::size_t>(1, e.particles().size())),
                 e.threads_in_use() > 1 ? " and integration" : "", st.force_seconds,
                 st.rebuild_seconds, solver);
  }
  if (const auto& st = e.stats(); st.team_full_steps + st.team_one_steps > 0) {
    const double all = static_cast<double>(st.team_full_steps + st.team_one_steps);
    spdlog::info("threads: work cut into {} parts; {:.1f} % of the steps ran on {} threads "
                 "({:.1f} % many to a parallel region, the others one step per region), "
                 "{:.1f} % on one (adaptive team: one thread where the full team measured slower, "
                 "e.g. a core shared with another process; {} probes of the full team left out "
                 "while the other CPUs were busy); results depend on the part count only",
                 e.threads_in_use(), 100.0 * static_cast<double>(st.team_full_steps) / all,
                 e.threads_in_use(), 100.0 * static_cast<double>(st.team_region_steps) / all,
                 100.0 * static_cast<double>(st.team_one_steps) / all, st.team_probes_skipped);
  }
  if (const auto& st = e.stats(); st.rebound_contacts > 0)
    spdlog::info(
        "rebound: {} contacts first touched above V_0, {} of them ({:.2g} %) in collisions "
        "of several such contacts on one particle in one step (their impulses shared)",
        st.rebound_contacts, st.rebound_shared,
        100.0 * static_cast<double>(st.rebound_shared) / static_cast<double>(st.rebound_contacts));
}

} // namespace demfem::dem::run_detail
