#include "run_jobs.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "command.hpp"
#include "demfem/calibrate/calibrate.hpp"
#include "demfem/compare/report.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/studies/processes.hpp"
#include "run_dir.hpp"
#include "signals.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

namespace {

// The last non-empty line of a child's console log (what it said when it stopped).
std::string last_line(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

} // namespace

int run_parallel(const std::vector<const scene::Scene*>& scenes, const RunArgs& a) {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) {
    fmt::print(stderr, "demfem run --jobs: cannot find its own binary (/proc/self/exe): {}\n",
               ec.message());
    return kRunFailed;
  }
  const bool continuum = a.solver == "continuum";
  std::vector<studies::ProcessTask> prep, runs;
  std::vector<std::string> prep_label, run_label;
  std::vector<double> prep_cost, run_cost;
  std::map<std::string, std::size_t> shared; // packing or calibration key → its index in prep
  std::vector<std::size_t> run_prep;         // per run: its index in prep, or kNoPrep
  constexpr std::size_t kNoPrep = static_cast<std::size_t>(-1);
  // Estimated work of a DEM run over `span` seconds: particles × steps (the automatic step from
  // the scene's stable bound, as `demfem check` gives it); 0 when unknown (continuum runs).
  const auto dem_work = [](const scene::Scene& s, double span) {
    if (!s.soil.dem || !(span > 0.0)) return 0.0;
    double dt = s.soil.dem->dt;
    if (!(dt > 0.0))
      if (const auto b = dem::scene_critical_step(s); b && b->dt > 0.0 && std::isfinite(b->dt))
        dt = s.soil.dem->dt_safety * b->dt;
    return dt > 0.0 ? static_cast<double>(s.soil.dem->count) * span / dt : 0.0;
  };
  // Every run directory is checked first (a folder that is not demfem's, another scene's
  // results, a resume that does not match): one refusal and nothing starts. Each gets its marker
  // and manifest (with the consoles written here); each run takes its own directory's lock.
  for (const scene::Scene* s : scenes) {
    Ownership own;
    RunDirUse use;
    use.dem = !continuum;
    use.continuum = continuum;
    use.check_only = true;
    if (const int p = open_run_dir(*s, run_dir_for(*s, a, scenes.size()), a, use, own); p != kOk)
      return p;
  }
  std::vector<fs::path> run_dirs;
  for (const scene::Scene* s : scenes) {
    const fs::path out = run_dir_for(*s, a, scenes.size());
    const auto with_variant = [&](std::vector<std::string> v) {
      if (!s->variant.empty()) v.insert(v.end(), {"--variant", s->variant});
      return v;
    };
    // A continuum run with calibrate = "dem": the calibration (it packs the bed too); a DEM run:
    // its packing only (it makes no calibration)
    const bool calibrated = continuum && s->soil.continuum && s->soil.continuum->calibrate_dem &&
                            s->uses(scene::Solver::Continuum);
    const bool packs = !continuum && s->soil.dem && s->soil.dem->particles.empty() &&
                       !s->soil.dem->packing.cache.empty();
    std::size_t needs = kNoPrep;
    if (calibrated || packs) {
      const std::string key = calibrated ? "calibration " + calibrate::calibration_key(*s, {})
                                         : "packing " + dem::packing_key(*s);
      const auto [at, inserted] = shared.emplace(key, prep.size());
      needs = at->second;
      if (inserted) {
        auto pargv = with_variant({exe.string(), calibrated ? "calibrate" : "pack", a.scene,
                                   "--out", (calibrated ? out / "calibration" : out).string()});
        if (a.seed >= 0) pargv.insert(pargv.end(), {"--seed", std::to_string(a.seed)});
        // a target the deposition cannot reach: the runs use the nearest packing and say so
        if (!calibrated) pargv.push_back("--target-not-met-ok");
        prep.push_back({pargv, out / (calibrated ? "calibrate.txt" : "pack.txt"), 0.0, {}});
        prep_label.push_back(fmt::format("{} ({})", s->label(), key.substr(0, key.find(' '))));
        // a porosity target takes several depositions (1–5, median 3, over the cached packings
        // of the paper scenes; pack.hpp: at most 10)
        prep_cost.push_back(calibrated ? 0.0
                                       : dem_work(*s, s->soil.dem->packing.max_time) *
                                             (s->soil.dem->packing.target_porosity ? 3.0 : 1.0));
      }
    }
    std::vector<std::string> argv = {exe.string(), "run",       a.scene,
                                     "--solver",   a.solver,    "--out",
                                     out.string(), "--threads", std::to_string(a.threads)};
    if (a.refinement >= 0) argv.insert(argv.end(), {"--refinement", std::to_string(a.refinement)});
    if (a.degree >= 0) argv.insert(argv.end(), {"--degree", std::to_string(a.degree)});
    if (a.force) argv.push_back("--force");
    if (a.resume) argv.push_back("--resume");
    if (a.seed >= 0) argv.insert(argv.end(), {"--seed", std::to_string(a.seed)});
    runs.push_back({with_variant(argv), out / "console.txt", 0.0, {}});
    run_dirs.push_back(out);
    run_prep.push_back(needs);
    run_label.push_back(s->label());
    run_cost.push_back(continuum ? 0.0 : dem_work(*s, s->info.duration));
  }
  // Largest estimated work first (longest-processing-time order), ties in file order: the short
  // runs fill the end, where one core would otherwise idle while the last long run finishes.
  // Returns the new order (new position → old index).
  const auto largest_first = [&](std::vector<studies::ProcessTask>& tasks,
                                 std::vector<std::string>& labels, const std::vector<double>& cost,
                                 const char* what) {
    std::vector<std::size_t> order(tasks.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t x, std::size_t y) { return cost[x] > cost[y]; });
    bool moved = false;
    for (std::size_t k = 0; k < order.size(); ++k) moved = moved || order[k] != k;
    if (!moved) return order;
    std::vector<studies::ProcessTask> t;
    std::vector<std::string> l;
    for (const std::size_t k : order) {
      t.push_back(std::move(tasks[k]));
      l.push_back(std::move(labels[k]));
    }
    tasks = std::move(t);
    labels = std::move(l);
    fmt::print(stderr,
               "demfem run --jobs {}: {} started largest estimated work (particles × steps) "
               "first: {}\n",
               a.jobs, what, fmt::join(labels, ", "));
    return order;
  };
  const std::vector<std::size_t> prep_order =
      largest_first(prep, prep_label, prep_cost, "preparations");
  const std::vector<std::size_t> run_order = largest_first(runs, run_label, run_cost, "runs");
  // One list, the preparations first: a free slot takes the first task that can start, so a run
  // starts as soon as its own packing or calibration is made (while others are still being made)
  // instead of after all of them.
  std::vector<std::size_t> prep_at(prep.size());
  for (std::size_t k = 0; k < prep_order.size(); ++k) prep_at[prep_order[k]] = k;
  std::vector<studies::ProcessTask> tasks = std::move(prep);
  for (std::size_t k = 0; k < runs.size(); ++k) {
    tasks.push_back(std::move(runs[k]));
    if (const std::size_t d = run_prep[run_order[k]]; d != kNoPrep)
      tasks.back().after = {prep_at[d]};
  }
  const std::size_t n_prep = prep_label.size(), n_runs = run_label.size();
  int first_failure = kOk;
  const auto t0 = std::chrono::steady_clock::now();
  if (n_prep > 0)
    fmt::print(stderr,
               "demfem run --jobs {}: {} shared packing(s)/calibration(s) first, each run as "
               "soon as its own is made: {} run(s)\n",
               a.jobs, n_prep, n_runs);
  std::size_t done_prep = 0, done_runs = 0;
  const auto res =
      studies::run_processes(tasks, a.jobs, [&](std::size_t i, const studies::ProcessResult& r) {
        const bool is_prep = i < n_prep;
        const std::size_t done = is_prep ? ++done_prep : ++done_runs;
        const std::size_t of = is_prep ? n_prep : n_runs;
        const char* what = is_prep ? "prepare" : "run";
        const std::string& label = is_prep ? prep_label[i] : run_label[i - n_prep];
        const double since =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (r.exit_code == 0) {
          fmt::print(stderr,
                     "demfem run --jobs {}: [{}/{}] {} {}: done in {:.1f} s ({:.0f} s in "
                     "all)\n",
                     a.jobs, done, of, what, label, r.wall, since);
          return;
        }
        if (first_failure == kOk) first_failure = r.exit_code > 0 ? r.exit_code : kRunFailed;
        if (r.stopped && r.not_started) {
          fmt::print(stderr, "demfem run --jobs {}: [{}/{}] {} {}: not started (stopped by {})\n",
                     a.jobs, done, of, what, label, stop_signal_name());
          return;
        }
        if (r.stopped) {
          fmt::print(stderr,
                     "demfem run --jobs {}: [{}/{}] {} {}: stopped (exit {}) after {:.1f} s\n",
                     a.jobs, done, of, what, label, r.exit_code, r.wall);
          return;
        }
        if (r.not_started) {
          const std::size_t d = tasks[i].after.empty() ? 0 : tasks[i].after.front();
          fmt::print(stderr,
                     "demfem run --jobs {}: [{}/{}] {} {}: NOT STARTED: its preparation {} failed "
                     "(console: {})\n",
                     a.jobs, done, of, what, label, d < n_prep ? prep_label[d] : "?",
                     d < tasks.size() ? tasks[d].log.string() : "?");
          return;
        }
        fmt::print(stderr,
                   "demfem run --jobs {}: [{}/{}] {} {}: FAILED (exit {}) after {:.1f} s: "
                   "{} (console: {})\n",
                   a.jobs, done, of, what, label, r.exit_code, r.wall, last_line(tasks[i].log),
                   tasks[i].log.string());
      });
  if (stop_requested().load()) {
    // what each run needs to continue: a stopped DEM or explicit continuum run resumes from its
    // checkpoint; a run that did not start (or an implicit continuum run, which has no
    // checkpoint) starts again
    std::vector<std::string> again;
    for (std::size_t k = 0; k < n_runs; ++k) {
      const std::size_t i = n_prep + k;
      if (res[i].exit_code == 0) continue;
      const std::size_t old = run_order[k]; // index into scenes
      std::string c = "demfem run " + compare::shell_quote(a.scene);
      if (continuum) c += " --solver continuum";
      if (!scenes[old]->variant.empty())
        c += " --variant " + compare::shell_quote(scenes[old]->variant);
      c += " --out " + compare::shell_quote(run_dirs[old].string());
      if (a.threads != 1) c += fmt::format(" --threads {}", a.threads);
      if (a.refinement >= 0) c += fmt::format(" --refinement {}", a.refinement);
      if (a.degree >= 0) c += fmt::format(" --degree {}", a.degree);
      if (a.seed >= 0) c += fmt::format(" --seed {}", a.seed);
      const bool checkpointed = !continuum || scenes[old]->continuum.integrator == "explicit";
      if (checkpointed && res[i].exit_code == kInterrupted) c += " --resume";
      again.push_back(c);
    }
    fmt::print(stderr,
               "demfem run --jobs {}: stopped by {}: {} run(s) not finished; continue them "
               "with:\n  {}\n",
               a.jobs, stop_signal_name(), again.size(), fmt::join(again, "\n  "));
    return kInterrupted;
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  fmt::print(stderr, "demfem run --jobs {}: {} run(s) in {:.1f} s{}\n", a.jobs, n_runs, total,
             first_failure == kOk ? "" : " — some FAILED (above)");
  return first_failure;
}

} // namespace demfem::app
