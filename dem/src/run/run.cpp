// `demfem run SCENE --solver dem`: builds the engine from the scene, runs it to the scene's
// duration and calls its hooks between steps (hooks.hpp): checkpoints, events, the energy watch
// and probes, snapshots, progress. The files it writes under <out>/dem and their columns are the
// run-directory contract's (output/contract.hpp).
#include <algorithm>
#include <chrono>

#include <fmt/format.h>

#include "demfem/output/contract.hpp"
#include "demfem/scene/load.hpp"
#include "hooks.hpp"

namespace demfem::dem {

namespace {
using namespace run_detail;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The probes' files: each row's values with {:.9g}, flushed every 50 rows; a resumed run keeps the
// rows before the checkpoint's time and rewrites those at and after it.
output::ProbeSetOptions probe_options(const scene::Scene& scene, bool resuming, double keep_until) {
  output::ProbeSetOptions o;
  o.base_interval = scene.output.probe_interval > 0.0 ? scene.output.probe_interval : 0.01;
  o.csv.comments = {fmt::format("demfem dem run of {}", scene.label())};
  o.csv.flush_every_rows = 50;
  if (resuming) o.csv.resume_after = keep_until;
  return o;
}

// The hooks of one run, set up in this order (a loci probe tags its particles before the first
// snapshot).
struct Hooks {
  Hooks(const scene::Scene& scene, const RunOptions& options, const std::filesystem::path& out,
        Engine& engine, LoopState& ls, bool resuming, double keep_until)
      : e(engine), events(scene, ls.next_event), watch(scene, ls), source(engine, scene, watch),
        probes(scene, source, probe_options(scene, resuming, keep_until),
               resuming ? &ls.probes : nullptr),
        snapshots(scene, out, resuming, keep_until, ls),
        checkpoints(scene, out / output::file::checkpoint, resuming, ls),
        progress(options, scene.info.duration) {
    probes.open(out);
  }
  // The energy watch (at output.probe_interval and at the end), then every probe due (at the end:
  // every probe). Returns "" or why the run stops.
  std::string sample(RunSummary& summary, bool end) {
    source.begin();
    std::string stop;
    if (end || probes.base_due(e.time(), 0.5 * e.dt()))
      stop = watch.check(e, source.budget(), summary);
    if (end)
      probes.sample_missing(source);
    else
      probes.sample_due(source, 0.5 * e.dt());
    return stop;
  }
  // The steps before the next action at once (Engine::run_until: with a team of threads, in one
  // parallel region): each action fires at time ≥ t_next − Δt/2, run_until's stop (the same
  // expression, so the same step); an event's test (its time ≤ t + Δt/2) is kept out by a step's
  // margin. The first step alone (the watch's reference), and at most up to the next multiple of
  // 256 steps (the progress line; the interruption test).
  void advance(double t_end) {
    const double t_next = std::min({t_end, probes.next_time(), snapshots.next_time(),
                                    checkpoints.next_time(), events.next_time(e.dt())});
    const long long to_report = 256 - (e.stats().steps & 255);
    if (e.run_until(t_next, watch.started() ? to_report : 1) == 0) e.step(); // within a step
    if (!watch.started()) watch.start(e);
  }

  Engine& e;
  Events events;
  EnergyWatch watch;
  DemProbeSource source;
  output::ProbeSet probes;
  Snapshots snapshots;
  Checkpoints checkpoints;
  Progress progress;
};

void require_dem_soil(const scene::Scene& scene) {
  if (scene.soil.dem) return;
  scene::Diagnostic d;
  d.file = scene.source_file;
  d.key = "soil.dem";
  d.message = "the DEM solver needs a [soil.dem] section";
  throw scene::SceneError({d});
}
} // namespace

RunSummary run(const scene::Scene& scene, const RunOptions& options) {
  RunSummary summary;
  const auto t_start = Clock::now();
  require_dem_soil(scene);
  const auto out = options.out_dir / output::dir::dem;
  std::filesystem::create_directories(out);
  Engine e(make_config(scene));
  LoopState ls;
  bool resuming = false;
  if (auto why = set_up(scene, options, out, e, ls, resuming); !why.empty()) {
    summary.message = why;
    return summary;
  }
  summary.particles = e.particles().size();
  // the checkpoint holds the state before its time's output
  Hooks h(scene, options, out, e, ls, resuming, e.time() - 0.5 * e.dt());

  const double t_end = scene.info.duration;
  std::string failure;
  h.progress.report(e);
  while (e.time() < t_end - 0.5 * e.dt()) {
    if (options.interrupt && options.interrupt->load()) {
      h.checkpoints.write(e, h.probes, h.events);
      h.progress.report(e);
      summary.interrupted = true;
      summary.message =
          fmt::format("interrupted at t = {:.6g} s; continue with --resume", e.time());
      break;
    }
    h.checkpoints.at(e, h.probes, h.events);
    h.events.apply_due(e);
    if (h.probes.any_due(e.time(), 0.5 * e.dt())) failure = h.sample(summary, false);
    h.snapshots.at(e);
    if (!failure.empty()) break;
    h.advance(t_end);
    if (e.failed()) {
      failure = e.failure();
      break;
    }
    h.progress.tick(e);
  }
  summary.steps = e.stats().steps;
  summary.simulated_time = e.time();
  if (summary.interrupted) {
    summary.wall_seconds = seconds_since(t_start);
    return summary;
  }
  if (failure.empty()) {
    h.checkpoints.write(e, h.probes, h.events); // a longer duration resumes from here
    failure = h.sample(summary, true);
    h.snapshots.write(e);
  }
  h.probes.flush(); // every row on the disk (a failed write throws, naming the file)
  h.progress.report(e);
  log_statistics(e, seconds_since(t_start));
  summary.closure_error = h.watch.finish(e, out / output::file::energy_budget);
  Checkpoints::write_final(e, scene, out / output::file::final_state);
  summary.wall_seconds = seconds_since(t_start);
  summary.dt = e.dt();
  summary.ok = failure.empty();
  if (!summary.ok)
    summary.message = fmt::format("DEM run stopped at step {}, t = {:.6g} s: {}", e.stats().steps,
                                  e.time(), failure);
  return summary;
}

} // namespace demfem::dem
