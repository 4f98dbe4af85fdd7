// `demfem run SCENE --solver dem`: builds the engine from the scene, runs it to the scene's
// duration and calls its hooks between steps (hooks.hpp): events, checkpoints, the energy watch,
// probes, snapshots and progress. The files it writes under <out>/dem and their columns are the
// run-directory contract's (output/contract.hpp).
#include <algorithm>
#include <chrono>

#include <fmt/format.h>

#include "demfem/output/contract.hpp"
#include "demfem/scene/load.hpp"
#include "hooks.hpp"

namespace demfem::dem {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
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
} // namespace

RunSummary run(const scene::Scene& scene, const RunOptions& options) {
  using namespace run_detail;
  RunSummary summary;
  const auto t_start = std::chrono::steady_clock::now();
  if (!scene.soil.dem) {
    scene::Diagnostic d;
    d.file = scene.source_file;
    d.key = "soil.dem";
    d.message = "the DEM solver needs a [soil.dem] section";
    throw scene::SceneError({d});
  }
  const auto out = options.out_dir / output::dir::dem;
  std::filesystem::create_directories(out);
  Engine e(make_config(scene));
  LoopState ls;
  bool resuming = false;
  if (auto why = set_up(scene, options, out, e, ls, resuming); !why.empty()) {
    summary.message = why;
    return summary;
  }
  // the checkpoint holds the state before its time's output
  const double keep_until = e.time() - 0.5 * e.dt();
  summary.particles = e.particles().size();

  Events events(scene, ls.next_event);
  EnergyWatch watch(scene, ls);
  DemProbeSource source(e, scene, watch);
  output::ProbeSet probes(scene, source, probe_options(scene, resuming, keep_until),
                          resuming ? &ls.probes : nullptr);
  probes.open(out);
  Snapshots snapshots(scene, out, resuming, keep_until, ls);
  Checkpoints checkpoints(scene, out / output::file::checkpoint, resuming, ls);
  // At a probe time: the energy watch on output.probe_interval, then every probe due.
  auto sample = [&](bool end) {
    source.begin();
    std::string stop;
    if (end || probes.base_due(e.time(), 0.5 * e.dt()))
      stop = watch.check(e, source.budget(), summary);
    if (end)
      probes.sample_missing(source);
    else
      probes.sample_due(source, 0.5 * e.dt());
    return stop;
  };

  const double t_end = scene.info.duration, dt = e.dt();
  std::string failure;
  bool interrupted = false;
  Progress progress(options, t_end);
  progress.report(e);
  while (e.time() < t_end - 0.5 * dt) {
    if (options.interrupt && options.interrupt->load()) {
      checkpoints.write(e, probes, events);
      interrupted = true;
      break;
    }
    checkpoints.at(e, probes, events);
    events.apply_due(e);
    if (probes.any_due(e.time(), 0.5 * dt)) failure = sample(false);
    snapshots.at(e);
    if (!failure.empty()) break;
    // The steps before the next action at once (Engine::run_until: with a team of threads, in one
    // parallel region): each action above fires at time ≥ t_next − Δt/2, run_until's stop (the
    // same expression, so the same step); an event's test (its time ≤ t + Δt/2) is kept out by a
    // step's margin. The first step alone (the watch's reference), and at most up to the next
    // multiple of 256 steps (the progress line; the interruption test).
    const double t_next = std::min({t_end, probes.next_time(), snapshots.next_time(),
                                    checkpoints.next_time(), events.next_time(dt)});
    const long long to_report = 256 - (e.stats().steps & 255);
    if (e.run_until(t_next, watch.started() ? to_report : 1) == 0) e.step(); // within a step
    if (!watch.started()) watch.start(e);
    if (e.failed()) {
      failure = e.failure();
      break;
    }
    progress.tick(e);
  }
  if (interrupted) {
    progress.report(e);
    summary.steps = e.stats().steps;
    summary.simulated_time = e.time();
    summary.wall_seconds = seconds_since(t_start);
    summary.interrupted = true;
    summary.message = fmt::format("interrupted at t = {:.6g} s; continue with --resume", e.time());
    return summary;
  }
  if (failure.empty()) {
    checkpoints.write(e, probes, events); // a resume with a longer duration continues from here
    failure = sample(true);
    snapshots.write(e);
  }
  probes.flush(); // every row on the disk (a failed write throws, naming the file)
  progress.report(e);
  log_statistics(e, seconds_since(t_start));
  summary.closure_error = watch.finish(e, out / output::file::energy_budget);
  Checkpoints::write_final(e, scene, out / output::file::final_state);
  summary.steps = e.stats().steps;
  summary.simulated_time = e.time();
  summary.wall_seconds = seconds_since(t_start);
  summary.dt = e.dt();
  summary.ok = failure.empty();
  if (!summary.ok)
    summary.message = fmt::format("DEM run stopped at step {}, t = {:.6g} s: {}", e.stats().steps,
                                  e.time(), failure);
  return summary;
}

} // namespace demfem::dem
