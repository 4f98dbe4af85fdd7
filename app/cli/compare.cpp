// `demfem compare SCENE`: DEM and continuum on the same scene, then report.html and metrics.json
// comparing every quantity both wrote; with --seeds, a seed ensemble of such comparisons.
#include <algorithm>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "calibration.hpp"
#include "command.hpp"
#include "demfem/compare/model_differences.hpp"
#include "demfem/compare/report.hpp"
#include "demfem/studies/ensemble.hpp"
#include "log.hpp"
#include "run_dir.hpp"
#include "scenes.hpp"
#include "solver.hpp"
#include "thread_cap.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

namespace {

// `demfem compare` as the user would type it again for this run directory.
std::string reproduce_command(const scene::Scene& s, const fs::path& out, const RunArgs& a) {
  std::string c = "demfem compare " + compare::shell_quote(a.scene);
  if (!s.variant.empty()) c += " --variant " + compare::shell_quote(s.variant);
  if (!a.out.empty()) c += " --out " + compare::shell_quote(out.string());
  if (a.threads != 1) c += fmt::format(" --threads {}", a.threads);
  if (a.refinement >= 0) c += fmt::format(" --refinement {}", a.refinement);
  if (a.degree >= 1) c += fmt::format(" --degree {}", a.degree);
  if (a.seed >= 0) c += fmt::format(" --seed {}", a.seed);
  return c;
}

int compare_ensemble(const RunArgs& a);

// Why a solver's series in `out` cannot stand for the whole scene ("" when they can): no run
// record (the run did not finish), a failed run, or a run that stopped before the scene's
// duration (e.g. the continuum's small-strain validity limit).
std::string incomplete(const fs::path& out, const char* name, double duration) {
  const auto rec = compare::read_solver_run(out, name);
  if (!rec.present)
    return fmt::format("{}: no run record ({}): the {} run did not finish, so its series in {}/ "
                       "may end early",
                       name, compare::solver_run_file(out, name).string(), name, name);
  if (!rec.ok) return fmt::format("{}: the run failed: {}", name, rec.message);
  // (the DEM stops within its last step of the end: less than one Δt short)
  if (rec.simulated_time < duration - std::max(rec.dt, 0.0) - 1e-9 * duration)
    return fmt::format("{}: the series end at t = {:.4g} s of the scene's {:.4g} s{}", name,
                       rec.simulated_time, duration, rec.note.empty() ? "" : " (" + rec.note + ")");
  return {};
}

// Both solvers on the same scene, then the comparison report. Exit 1 when either solver the
// scene lists failed or stopped before the scene's duration (the report is written, marked
// incomplete).
int cmd_compare(const RunArgs& a) {
  if (!a.seeds.empty()) return compare_ensemble(a);
  int rc = kOk;
  const auto file = load_for(a, rc);
  if (rc != kOk) return rc;
  const auto scenes = pick(file, a, rc);
  if (rc != kOk) return rc;
  int worst = kOk;
  for (const scene::Scene* s0 : scenes) {
    log_before_run_dir();
    const fs::path out = run_dir_for(*s0, a, scenes.size());
    Ownership own; // the run directory's lock, held until its report is written
    if (a.report_only) {
      OwnRequest req;
      req.command = "compare --report-only";
      req.writes = {"report.html", "metrics.json", "compare"};
      req.must_exist = true;
      req.must_exist_why = "no run to report on";
      if (const int p = take_ownership(out, req, own); p != kOk) return p;
      own.commit();
    } else {
      RunDirUse use;
      use.sub = "compare";
      use.dem = use.continuum = use.report = true;
      if (const int p = open_run_dir(*s0, out, a, use, own); p != kOk) return p;
    }
    std::vector<std::string> calibrated;
    const scene::Scene cs = a.report_only ? calibration_of_run(*s0, out)
                                          : with_calibration(*s0, out, &calibrated, true);
    const scene::Scene* s = &cs; // calibrate = "dem" resolved
    if (!a.report_only)
      if (const int d = start_run_dir(*s, *s0, out, a.resume); d != kOk) return d;
    compare::ReportOptions ro;
    ro.scene = s;
    ro.command = reproduce_command(*s0, out, a);
    ro.title = fmt::format("demfem comparison: {}", s->label());
    if (!s->info.description.empty()) ro.notes.push_back(s->info.description);
    // The calibrated values and their provenance are in the report's parameter table (once).
    if (!calibrated.empty())
      ro.notes.push_back("The continuum is calibrated from the DEM (soil.continuum.calibrate = "
                         "\"dem\"; a value stated in the scene wins): each value and where it "
                         "came from is in \"Parameters of both models\".");
    for (const auto solver : {scene::Solver::Dem, scene::Solver::Continuum}) {
      const char* name = solver == scene::Solver::Dem ? "dem" : "continuum";
      if (!s->uses(solver)) {
        ro.notes.push_back(fmt::format("The scene does not list \"{}\" in scene.solvers.", name));
        continue;
      }
      if (!a.report_only) {
        spdlog::info("demfem {}: {} with the {} solver → {}", DEMFEM_VERSION, s->label(), name,
                     out.string());
        const auto r = run_solver(*s, solver, out, a);
        if (r.bad_input) {
          fmt::print(stderr, "{}\n", r.message);
          return kBadInput;
        }
        if (r.interrupted) return report_interrupted("compare", *s, solver, out, a, r.message);
        if (r.ok && !r.note.empty())
          ro.notes.push_back(fmt::format("The {} run {}.", name, r.note));
        if (!r.ok) {
          spdlog::error("{}: {} solver: {}", s->label(), name, r.message);
          if (!r.ran) { // no run record: the solver is not in this build
            ro.incomplete.push_back(fmt::format("{}: the solver did not run: {}", name, r.message));
            continue;
          }
        }
      }
      if (const auto why = incomplete(out, name, s->info.duration); !why.empty())
        ro.incomplete.push_back(why);
    }
    compare::ReportResult rep;
    try {
      rep = compare::write_report(out, ro);
    } catch (const std::exception& e) {
      spdlog::error("{}: report: {}", s->label(), e.what());
      worst = kRunFailed;
      continue;
    }
    spdlog::info("{}: report {} ({} quantities compared), metrics {}", s->label(),
                 rep.html.string(), rep.compared.size(), rep.metrics_json.string());
    if (!ro.incomplete.empty()) {
      for (const auto& i : ro.incomplete) spdlog::error("{}: incomplete: {}", s->label(), i);
      spdlog::error("{}: the comparison is incomplete (marked so in {} and {}): exit 1", s->label(),
                    rep.html.string(), rep.metrics_json.string());
      worst = kRunFailed;
    }
  }
  return worst;
}

// compare --seeds: one comparison per packing seed into <run dir>/seed-N (each a
// complete `demfem compare --seed N`, the continuum calibrated from that seed's bed where the
// scene calibrates), then ensemble.json and ensemble.html in the run directory: per metric, each
// solver's range over the realisations and in how many the DEM's exceeds the continuum's. With
// --report-only every member's report is rebuilt, then the ensemble.
int compare_ensemble(const RunArgs& a) {
  if (a.seed >= 0) {
    fmt::print(stderr, "demfem compare: --seed and --seeds exclude each other (--seeds runs one "
                       "comparison per seed)\n");
    return kBadInput;
  }
  const std::set<long long> distinct(a.seeds.begin(), a.seeds.end());
  if (distinct.size() != a.seeds.size() || *distinct.begin() < 0) {
    fmt::print(stderr,
               "demfem compare: --seeds {}: give distinct non-negative seeds, e.g. "
               "--seeds 41,101,202\n",
               fmt::join(a.seeds, ","));
    return kBadInput;
  }
  int rc = kOk;
  const auto file = load_for(a, rc);
  if (rc != kOk) return rc;
  const auto scenes = pick(file, a, rc);
  if (rc != kOk) return rc;
  int worst = kOk;
  for (const scene::Scene* s : scenes) {
    const fs::path dir = run_dir_for(*s, a, scenes.size());
    // the ensemble's folder: its pages and the realisations' run directories (each taken by its
    // own comparison)
    Ownership own;
    OwnRequest req;
    req.command = a.report_only ? "compare --seeds --report-only" : "compare --seeds";
    req.writes = {"ensemble.json", "ensemble.html", "figures", "seed-*"};
    req.must_exist = a.report_only;
    req.must_exist_why = "no ensemble to report on";
    if (const int p = take_ownership(dir, req, own); p != kOk) return p;
    own.commit();
    std::vector<studies::EnsembleMember> members;
    for (const long long seed : a.seeds) {
      RunArgs m = a;
      m.seeds.clear();
      m.seed = seed;
      m.all_variants = false;
      m.variants.clear();
      if (!s->variant.empty()) m.variants.push_back(s->variant);
      m.out = (dir / fmt::format("seed-{}", seed)).string();
      spdlog::info("{}: realisation {} of {} (seed {}) → {}", s->label(), members.size() + 1,
                   a.seeds.size(), seed, m.out);
      const int r = cmd_compare(m);
      if (r == kBadInput || r == kInterrupted) return r;
      if (r != kOk) worst = r;
      members.push_back({static_cast<unsigned long long>(seed), m.out});
    }
    auto e = studies::summarise_ensemble(members);
    // the command that runs the ensemble (--report-only rebuilds it: not the way to reproduce it)
    const std::string command =
        reproduce_command(*s, dir, a) + fmt::format(" --seeds {}", fmt::join(a.seeds, ","));
    try {
      const auto files = studies::write_ensemble(
          dir, e,
          fmt::format("demfem seed ensemble: {} ({} realisations)", s->label(), e.members.size()),
          command);
      spdlog::info("{}: ensemble of {} realisation(s): {} ({} quantities), {}", s->label(),
                   e.members.size(), files.html.string(), e.rows.size(), files.json.string());
    } catch (const std::exception& ex) {
      spdlog::error("{}: ensemble: {}", s->label(), ex.what());
      worst = kRunFailed;
    }
    for (const auto& why : e.missing) spdlog::error("{}: ensemble: left out {}", s->label(), why);
    if (e.members.size() != members.size()) worst = kRunFailed;
  }
  return worst;
}

[[maybe_unused]] const bool registered = register_command(
    {"compare",
     "Run DEM and continuum on the same scene and write report.html and metrics.json comparing "
     "every quantity both wrote.",
     30, false, [](CLI::App&, CLI::App& sub) -> std::function<int()> {
       auto ra = std::make_shared<RunArgs>();
       sub.add_option("scene", ra->scene, "Scene file")->required()->check(CLI::ExistingFile);
       sub.add_option("--variant", ra->variants, "Variant name");
       sub.add_flag("--all-variants", ra->all_variants, "All variants");
       sub.add_option("--out", ra->out, "Run directory (default runs/<scene>[/<variant>])");
       sub.add_flag("--resume", ra->resume, "DEM: continue from the last checkpoint");
       sub.add_flag("--force", ra->force,
                    "Run into a directory that holds another scene's results, clearing them first");
       sub.add_flag("--report-only", ra->report_only,
                    "Run nothing: rewrite report.html and metrics.json from the run directory");
       sub.add_option("--threads", ra->threads, "DEM OpenMP threads (0 = all cores)")
           ->default_val(1)
           ->check(CLI::NonNegativeNumber)
           ->transform(threads_capped_at_cores());
       sub.add_option("--refinement", ra->refinement, "Continuum: refinement level");
       sub.add_option("--degree", ra->degree, "Continuum: polynomial degree");
       sub.add_option("--seed", ra->seed, "Packing seed (scene.seed) instead of the file's")
           ->check(CLI::Range(0LL, 2147483647LL)); // scene.seed's range
       sub.add_option("--seeds", ra->seeds,
                      "Seed ensemble: one comparison per packing seed into <out>/seed-N, then "
                      "ensemble.html and ensemble.json (e.g. --seeds 41,101,202)")
           ->delimiter(',')
           ->check(CLI::Range(0LL, 2147483647LL));
       return [ra] { return cmd_compare(*ra); };
     }});

} // namespace

} // namespace demfem::app
