// `demfem study stability|error-vs-time SCENE`: stiff and extreme variants of a scene, or its
// resolution sweeps against a closed form or the most resolved run.
#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "calibration.hpp"
#include "command.hpp"
#include "demfem/dem/verification.hpp"
#include "demfem/studies/error_study.hpp"
#include "demfem/studies/study.hpp"
#include "log.hpp"
#include "progress.hpp"
#include "run_dir.hpp"
#include "scenes.hpp"
#include "signals.hpp"
#include "thread_cap.hpp"
#ifdef DEMFEM_WITH_CONTINUUM
#include "continuum_module.hpp"
#include "demfem/studies/stability_continuum.hpp"
#endif

namespace fs = std::filesystem;

namespace demfem::app {

namespace {

// What a study writes into its folder (ownership.hpp).
const std::vector<std::string> kStudyWrites = {"log.txt", "study.json",  "study.md", "study.html",
                                               "figures", "rows",        "runs",     "packings",
                                               "packing", "calibration", "cache",    ".ranks-*"};

// Takes a study's folder (rank 0 under a launcher); kOk or the refusal's exit code.
int take_study_dir(const fs::path& out, Ownership& own) {
  OwnRequest req;
  req.command = "study";
  req.writes = kStudyWrites;
  if (const int p = take_ownership(out, req, own); p != kOk) return p;
  own.commit();
  return kOk;
}

// A study stopped by a stop signal: its page is not written (it would show a partial sweep as
// if whole); its runs so far stay in `out`.
int study_stopped(const fs::path& out) {
  spdlog::warn("study: stopped by {}: the study was not written (its runs so far are in {}); "
               "run it again:\n  {}",
               stop_signal_name(), out.string(), command_line());
  return kInterrupted;
}

// `demfem study error-vs-time SCENE`: resolution sweeps, each run a separate
// `demfem` process; SCENE = "flamant" is the built-in Flamant strip load (continuum).
// A comma-separated list of positive multipliers, or "none" (empty: the knob is off). Throws
// CLI::ValidationError naming the option and the offending entry.
std::vector<double> parse_factor_list(const std::string& text, const std::string& option) {
  if (text == "none") return {};
  std::vector<double> out;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t end = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, end - pos);
    double v = NAN;
    std::size_t used = 0;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size() || !(v > 0.0) || !std::isfinite(v))
      throw CLI::ValidationError(option, fmt::format("'{}' in '{}' is not a positive number "
                                                     "(give a comma-separated list, e.g. 1,4, "
                                                     "or none)",
                                                     item, text));
    out.push_back(v);
    pos = end + 1;
  }
  return out;
}

struct ErrorStudyArgs {
  int jobs = 1;
  int repeats = 3;
  std::vector<double> dt_fractions, kn_factors;
  // given multiplier lists (empty: "none", the knob off); absent: the defaults
  std::optional<std::vector<double>> size_factors, near_factors, cont_dt_factors;
  std::vector<int> refinements, degrees;
  std::string solver = "both";          // scenes without a closed form: dem | continuum | both
  std::vector<std::string> integrators; // continuum: explicit, implicit
  double max_run_seconds = 300.0;
  double duration = 0.0;           // --duration (0: the scene's)
  std::string kn_packing = "same"; // same | deposit
};
int cmd_error_study(const std::string& path, const RunArgs& a, const ErrorStudyArgs& ea) {
  studies::ErrorStudyOptions o;
  std::error_code ec;
  o.exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) {
    fmt::print(stderr, "demfem study: cannot find its own binary (/proc/self/exe): {}\n",
               ec.message());
    return kRunFailed;
  }
  o.jobs = ea.jobs;
  o.repeats = ea.repeats;
  if (!ea.dt_fractions.empty()) o.dt_fractions = o.scene_dt_fractions = ea.dt_fractions;
  if (!ea.kn_factors.empty()) o.kn_factors = o.scene_kn_factors = ea.kn_factors;
  if (ea.size_factors) o.scene_size_factors = *ea.size_factors;
  if (ea.near_factors) o.scene_near_factors = *ea.near_factors;
  if (ea.cont_dt_factors) o.scene_cont_dt_factors = *ea.cont_dt_factors;
  if (!ea.refinements.empty()) o.refinements = o.scene_refinements = ea.refinements;
  if (!ea.degrees.empty()) o.degrees = o.scene_degrees = ea.degrees;
  o.solvers = ea.solver;
  o.integrators = ea.integrators;
  o.max_run_seconds = ea.max_run_seconds;
  o.kn_same_packing = ea.kn_packing != "deposit";
  if (ea.duration > 0.0) o.duration = ea.duration;
  ProgressReporter reporter;
  o.progress = stoppable([&](const scene::Progress& p) { reporter(p); });
  if (path == "flamant") {
#ifndef DEMFEM_WITH_CONTINUUM
    fmt::print(stderr, "demfem study error-vs-time flamant: the continuum solver is not in this "
                       "build (-DDEMFEM_WITH_CONTINUUM=OFF)\n");
    return kBadInput;
#else
    o.out_dir =
        a.out.empty() ? fs::path("runs") / "flamant" / "study-error-vs-time" : fs::path(a.out);
    o.out_dir = fs::absolute(o.out_dir);
    Ownership own;
    if (const int p = take_study_dir(o.out_dir, own); p != kOk) return p;
    if (studies::study_rank() == 0) setup_run_log(o.out_dir, false);
    const auto st = studies::flamant_error_study(o);
    if (stop_requested().load()) return study_stopped(o.out_dir);
    if (studies::study_rank() == 0) studies::write_error_study(st, o.out_dir);
    studies::finish_study_ranks(o.out_dir);
    for (const auto& f : st.fits)
      spdlog::info("{} {} against {}: order {:.3f} ({} points)", f.knob, f.metric, f.against,
                   f.order, f.points);
    spdlog::info("flamant: error-vs-time study in {}", (o.out_dir / "study.html").string());
    return kOk;
#endif
  }
  if (!fs::is_regular_file(path)) {
    fmt::print(stderr,
               "demfem study error-vs-time: {}: no such scene file (or `flamant`, the "
               "built-in Flamant strip load)\n",
               path);
    return kBadInput;
  }
  int rc = kOk;
  const auto file = load_or_report(path, rc);
  if (rc != kOk) return rc;
  const auto scenes = pick(file, a, rc);
  if (rc != kOk) return rc;
  if (ea.solver != "dem" && ea.solver != "continuum" && ea.solver != "both") {
    fmt::print(stderr,
               "demfem study error-vs-time: unknown --solver '{}'; valid: dem, continuum, "
               "both\n",
               ea.solver);
    return kBadInput;
  }
  for (const auto& in : ea.integrators)
    if (in != "explicit" && in != "implicit") {
      fmt::print(stderr,
                 "demfem study error-vs-time: unknown --integrators entry '{}'; valid: "
                 "explicit, implicit\n",
                 in);
      return kBadInput;
    }
  for (const scene::Scene* s : scenes) {
    std::string why;
    const bool closed = dem::head_on_closed_form(*s, &why).has_value();
    const bool surface = std::any_of(s->probes.begin(), s->probes.end(), [](const scene::Probe& p) {
      return p.kind == scene::ProbeKind::SurfaceProfile;
    });
    if (!closed && s->structures.empty() && !surface) {
      fmt::print(stderr,
                 "{}: error: the error-vs-time study measures a scene without a closed form with "
                 "the comparison's metric table (a structure's thrust, settlement, rotation; the "
                 "surface) and this scene has no [[structure]] and no surface-profile probe; it "
                 "has no closed form either ({}); valid: a scene with a structure or a "
                 "surface-profile probe, a head-on collision of two listed disks (e.g. "
                 "cases/verification/head_on_collision.toml) or `flamant`\n",
                 path, why);
      return kBadInput;
    }
    // the particle size knob needs whole counts: refused before anything is written
    if (!closed && ea.solver != "continuum" && s->soil.dem && s->soil.dem->particles.empty())
      for (const double f : o.scene_size_factors) {
        const double c = f * s->soil.dem->count;
        if (!(c >= 1.0) || std::abs(c - std::round(c)) > 1e-9 * c) {
          fmt::print(stderr,
                     "{}: error: --size-factors {:g} gives {:g} particles (soil.dem.count = {}); "
                     "valid: factors that make a whole count of at least 1 (e.g. 1,4)\n",
                     path, f, c, s->soil.dem->count);
          return kBadInput;
        }
      }
    o.out_dir = fs::absolute(run_dir_for(*s, a, scenes.size(), "study-error-vs-time"));
    Ownership own;
    if (const int p = take_study_dir(o.out_dir, own); p != kOk) return p;
    // under mpirun the runs are spread over the ranks; rank 0 keeps the log and writes the study
    if (studies::study_rank() == 0) setup_run_log(o.out_dir, false);
    if (studies::study_ranks() > 1)
      spdlog::info("study rank {} of {}: runs every {}th setting", studies::study_rank(),
                   studies::study_ranks(), studies::study_ranks());
    studies::ErrorStudy st;
    if (closed) {
      st = studies::dem_error_study(*s, o);
    } else {
      // No closed form: every solver against its most resolved run. The calibration
      // (calibrate = "dem") is computed or read here once, so that the runs read it from the
      // cache instead of each computing it.
      if (ea.solver != "dem" && s->soil.continuum && s->uses(scene::Solver::Continuum)) {
#ifndef DEMFEM_WITH_CONTINUUM
        if (ea.solver == "continuum") {
          fmt::print(stderr, "demfem study error-vs-time: the continuum solver is not in this "
                             "build (-DDEMFEM_WITH_CONTINUUM=OFF)\n");
          return kBadInput;
        }
        o.solvers = "dem";
#else
        scene::Scene sc = *s;
        if (ea.duration > 0.0) sc.info.duration = ea.duration;
        (void)with_calibration(sc, o.out_dir);
#endif
      }
      try {
        st = studies::scene_error_study(*s, o);
      } catch (const scene::SceneError& e) {
        fmt::print(stderr, "{}\n", e.what());
        return kBadInput;
      }
    }
    if (stop_requested().load()) return study_stopped(o.out_dir);
    if (studies::study_rank() == 0) studies::write_error_study(st, o.out_dir);
    studies::finish_study_ranks(o.out_dir);
    if (studies::study_rank() != 0) continue;
    for (const auto& f : st.fits)
      spdlog::info("{} {} against {}: order {:.3f} ({} points)", f.knob, f.metric, f.against,
                   f.order, f.points);
    spdlog::info("{}: error-vs-time study in {}", s->label(), (o.out_dir / "study.html").string());
  }
  return kOk;
}

// `demfem study stability SCENE`: the stability matrix (DEM rows; continuum rows for a scene
// with a continuum).
int cmd_study(const std::string& kind, const std::string& path, const RunArgs& a, double duration,
              ErrorStudyArgs ea, bool repack) {
  ea.duration = duration;
  if (kind == "error-vs-time") return cmd_error_study(path, a, ea);
  if (kind != "stability") {
    fmt::print(stderr, "demfem study: unknown study '{}'; valid: stability, error-vs-time\n", kind);
    return kBadInput;
  }
  if (!fs::is_regular_file(path)) {
    fmt::print(stderr, "demfem study stability: {}: no such scene file\n", path);
    return kBadInput;
  }
  int rc = kOk;
  const auto file = load_or_report(path, rc);
  if (rc != kOk) return rc;
  const auto scenes = pick(file, a, rc);
  if (rc != kOk) return rc;
  for (const scene::Scene* s : scenes) {
#ifdef DEMFEM_WITH_CONTINUUM
    const bool cont = s->soil.continuum.has_value();
#else
    const bool cont = false;
#endif
    if (!s->soil.dem && !cont) {
      fmt::print(stderr,
                 "{}: error: soil.dem: the stability study runs the DEM or the continuum model; "
                 "the scene has no [soil.dem] and no [soil.continuum] (or the continuum is not "
                 "in this build)\n",
                 path);
      return kBadInput;
    }
    const fs::path out = run_dir_for(*s, a, scenes.size(), "study-stability");
    Ownership own;
    if (const int p = take_study_dir(out, own); p != kOk) return p;
    setup_run_log(out, false);
    studies::StudyOptions o;
    o.out_dir = out;
    o.interrupt = &stop_requested();
    o.threads = a.threads;
    o.repack = repack;
    if (duration > 0.0) o.duration = duration;
#ifdef DEMFEM_WITH_CONTINUUM
    if (cont)
      o.continuum_rows = [&out](const scene::Scene& sc0) {
        // opens the module (throws when it cannot)
        return studies::continuum_stability_rows(
            continuum_module(), sc0,
            [&out](const scene::Scene& sc) { return with_calibration(sc, out); });
      };
#endif
    const auto rows = studies::stability_study(*s, o);
    if (stop_requested().load()) return study_stopped(out);
    studies::write_stability_study(rows, *s, out);
    for (const auto& r : rows) spdlog::info("{:<22} {:<15} {}", r.name, r.outcome, r.cause);
    spdlog::info("{}: stability study in {}", s->label(), (out / "study.html").string());
  }
  return kOk;
}

struct StudyArgs {
  std::string kind, scene;
  RunArgs ra;
  ErrorStudyArgs ea;
  double duration = 0.0;
  bool repack = false;
};

[[maybe_unused]] const bool registered = register_command(
    {"study",
     "stability: stiff and extreme variants (DEM rows; continuum rows for scenes with a "
     "continuum) → study.json, study.md, study.html. error-vs-time: resolution sweeps against a "
     "closed form or the most resolved run, each run a separate process (repeated), fitted "
     "orders, error against wall time with the Pareto front → study.json, study.md, study.html, "
     "figures/.",
     40, true, [](CLI::App&, CLI::App& sub) -> std::function<int()> {
       auto st = std::make_shared<StudyArgs>();
       sub.add_option("kind", st->kind, "stability | error-vs-time")->required();
       sub.add_option("scene", st->scene,
                      "Scene file; for error-vs-time also `flamant` (built-in Flamant strip load, "
                      "continuum)")
           ->required();
       sub.add_option("--variant", st->ra.variants,
                      "Variant name (repeatable); default: the base scene");
       sub.add_option("--out", st->ra.out,
                      "Output directory (default runs/<scene>/study-stability or "
                      "runs/<scene>/study-error-vs-time)");
       sub.add_option("--duration", st->duration,
                      "stability, and error-vs-time on a scene without a closed form: simulated "
                      "time of every run [s] (default: the scene's)")
           ->check(CLI::PositiveNumber);
       sub.add_option("--solver", st->ea.solver,
                      "error-vs-time on a scene without a closed form: dem | continuum | both "
                      "(default both: those the scene lists)")
           ->default_val("both");
       sub.add_option("--integrators", st->ea.integrators,
                      "error-vs-time, continuum: explicit,implicit (default: the scene's, then the "
                      "other)")
           ->delimiter(',');
       sub.add_option("--kn-packing", st->ea.kn_packing,
                      "error-vs-time on a packed scene: the K_n settings start from the scene's "
                      "packing (same) or each deposit their own (deposit)")
           ->default_val("same")
           ->check(CLI::IsMember({"same", "deposit"}));
       sub.add_option("--max-run-seconds", st->ea.max_run_seconds,
                      "error-vs-time on a scene: a run past this is stopped and the finer settings "
                      "of its knob skipped (listed in the study) [s]; 0 = no limit")
           ->default_val(300.0)
           ->check(CLI::NonNegativeNumber);
       sub.add_flag("--repack", st->repack,
                    "stability, packed scenes: deposit the packing of every row whose soil "
                    "parameters change (default: such rows are skipped unless their packing is "
                    "cached)");
       sub.add_option("--threads", st->ra.threads, "stability: DEM OpenMP threads (0 = all cores)")
           ->check(CLI::NonNegativeNumber)
           ->transform(threads_capped_at_cores());
       sub.add_option("--jobs", st->ea.jobs, "error-vs-time: runs at once (separate processes)")
           ->default_val(1)
           ->check(CLI::Range(1, 256));
       sub.add_option("--repeats", st->ea.repeats, "error-vs-time: runs per setting (timings)")
           ->default_val(3)
           ->check(CLI::Range(1, 100));
       sub.add_option("--dt-fractions", st->ea.dt_fractions,
                      "error-vs-time, DEM: Δt as fractions of the critical step (default 1/4 … "
                      "1/1024, halving; scenes without a closed form 0.5,0.25,0.125)")
           ->delimiter(',')
           ->check(CLI::Range(1e-9, 1.0));
       sub.add_option("--kn-factors", st->ea.kn_factors,
                      "error-vs-time, DEM: K_n multipliers, automatic Δt (default 0.1,0.3,1,3,10; "
                      "scenes without a closed form 0.3,1,3)")
           ->delimiter(',')
           ->check(CLI::PositiveNumber);
       // multiplier lists that also take "none" (the knob off); absent: the study's defaults
       const auto factor_list = [&sub](const char* name, std::optional<std::vector<double>>& to,
                                       const std::string& help) {
         sub.add_option_function<std::string>(
             name, [&to, name](const std::string& v) { to = parse_factor_list(v, name); }, help);
       };
       factor_list(
           "--size-factors", st->ea.size_factors,
           "error-vs-time on a packed scene, DEM: particle count multipliers at fixed "
           "geometry (count × f, radii / √f, each its own packing; default 1,4; none = off)");
       factor_list(
           "--near-factors", st->ea.near_factors,
           "error-vs-time on a scene with a graded continuum mesh: mesh_size_near multipliers "
           "at the scene's refinement (default 2,1,0.5; none = off)");
       factor_list(
           "--continuum-dt-factors", st->ea.cont_dt_factors,
           "error-vs-time on a scene, continuum: time step multipliers on the sweep's coarsest "
           "mesh (explicit: of the automatic step; implicit: of the Newmark step; default "
           "1,0.5,0.25; none = off)");
       sub.add_option("--refinements", st->ea.refinements,
                      "error-vs-time, continuum: refinement levels (flamant default 1,2,3,4; a "
                      "scene: its refinement − 2 … its refinement)")
           ->delimiter(',')
           ->check(CLI::Range(0, 8));
       sub.add_option("--degrees", st->ea.degrees,
                      "error-vs-time, continuum: polynomial degrees (default 1,2)")
           ->delimiter(',')
           ->check(CLI::Range(1, 4));
       return [st] {
         return cmd_study(st->kind, st->scene, st->ra, st->duration, st->ea, st->repack);
       };
     }});

} // namespace

} // namespace demfem::app
