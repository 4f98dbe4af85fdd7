// The `demfem` command: parses arguments, loads scenes, dispatches to the solvers. No physics.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <signal.h>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "demfem/app/vocabulary.hpp"
#include "demfem/compare/calibrate.hpp"
#include "demfem/compare/ensemble.hpp"
#include "demfem/compare/error_study.hpp"
#include "demfem/compare/figures.hpp"
#include "demfem/compare/model_differences.hpp"
#include "demfem/compare/processes.hpp"
#include "demfem/compare/report.hpp"
#include "demfem/compare/study.hpp"
#include "demfem/dem/key_hash.hpp"
#include "demfem/dem/malloc_tuning.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/validate.hpp"
#include "demfem/scene/write_file.hpp"
#include "progress.hpp"
#ifdef DEMFEM_WITH_CONTINUUM
#include "continuum_module.hpp"
#endif

namespace fs = std::filesystem;
using namespace demfem;

namespace {

// Ctrl-C, a batch scheduler's stop (SIGTERM) and a closed terminal (SIGHUP): the first of them
// asks the running solver to finish its step, write a checkpoint and stop (exit kInterrupted); a
// second one kills the process the usual way.
std::atomic<bool> g_interrupt{false};
volatile std::sig_atomic_t g_signal = 0;
extern "C" void on_stop_signal(int sig) {
  g_signal = sig;
  g_interrupt.store(true);
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  for (const int s : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(s, &dfl, nullptr);
}

void install_stop_signals() {
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  for (const int s : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(s, &sa, nullptr);
}

const char* signal_name(int sig) {
  switch (sig) {
  case SIGINT:
    return "SIGINT";
  case SIGTERM:
    return "SIGTERM";
  case SIGHUP:
    return "SIGHUP";
  default:
    return "a stop signal";
  }
}

// Exit codes, documented in --help and the README.
constexpr int kOk = 0;
constexpr int kRunFailed = 1;
constexpr int kBadInput = 2;
constexpr int kInterrupted = 3;

const char* kExitCodes = "Exit codes: 0 success, 1 the run failed, 2 bad input or usage, 3 stopped "
                         "by SIGINT/SIGTERM/SIGHUP after writing a checkpoint (continue with "
                         "--resume).";

struct RunArgs {
  std::string scene;
  std::string solver = "dem";
  std::vector<std::string> variants;
  bool all_variants = false;
  std::string out;
  bool resume = false;
  int threads = 1; // results are bit-reproducible per thread count; 1 unless asked
  int refinement = -1;
  int degree = -1;
  bool report_only = false; // compare: rewrite the report from the run directory's outputs
  bool force = false;       // run into a directory that holds another scene's results
  int jobs = 1;             // run: variants at once, as separate processes
  // --seed: scene.seed (the packing's radii and placement) for every chosen scene, overriding the
  // file; -1 = the file's. --seeds (compare): a seed ensemble, one comparison per seed (issue 9).
  long long seed = -1;
  std::vector<long long> seeds;
  bool target_not_met_ok = false; // pack: exit 0 when a porosity target is not met
};

[[maybe_unused]] int not_built(const std::string& what, const std::string& issue_hint) {
  fmt::print(stderr, "demfem {}: not built yet ({}). Nothing was run.\n", what, issue_hint);
  return kBadInput;
}

scene::SceneFile load_or_report(const std::string& path, int& rc) {
  try {
    rc = kOk;
    return scene::load_scene_file(path, app::vocabulary());
  } catch (const scene::SceneError& e) {
    fmt::print(stderr, "{}\n", e.what());
    fmt::print(stderr, "demfem: {} problem(s) in {}\n", e.diagnostics().size(), path);
    rc = kBadInput;
    return {};
  }
}

// Lines logged before a run directory's log.txt opens (the packing and the calibration a run
// makes first): printed, and kept for the top of that log.txt (setup_run_log), so that log.txt
// has everything the run said.
class PendingLines final : public spdlog::sinks::base_sink<std::mutex> {
public:
  std::vector<std::string> take() {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::exchange(lines_, {});
  }

protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    spdlog::memory_buf_t buf;
    formatter_->format(msg, buf);
    lines_.emplace_back(buf.data(), buf.size());
  }
  void flush_() override {}

private:
  std::vector<std::string> lines_;
};
std::shared_ptr<PendingLines>& pending_lines() {
  static std::shared_ptr<PendingLines> p;
  return p;
}

// Logs to the console (stdout, as spdlog's default logger) and keeps the lines for the next run
// directory's log.txt. Before each run's own set-up, so that one run's lines never reach another
// run's log.
void log_before_run_dir() {
  if (compare::study_rank() != 0) return; // other MPI ranks: warnings only (main)
  pending_lines() = std::make_shared<PendingLines>();
  auto console = std::make_shared<spdlog::sinks::stdout_color_sink_mt>();
  auto logger =
      std::make_shared<spdlog::logger>("demfem", spdlog::sinks_init_list{console, pending_lines()});
  logger->set_level(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

// A resumed run appends to the log of the run it continues.
void setup_run_log(const fs::path& dir, bool append) {
  fs::create_directories(dir);
  std::vector<std::string> earlier;
  if (pending_lines()) earlier = pending_lines()->take();
  pending_lines().reset();
  auto console = std::make_shared<spdlog::sinks::stderr_color_sink_mt>();
  if (compare::study_rank() != 0) {
    // another MPI rank of the same run: the first rank writes log.txt (a second file sink on it
    // truncated and interleaved it) and the console; this one reports warnings and errors only
    console->set_level(spdlog::level::warn);
    auto logger = std::make_shared<spdlog::logger>("demfem", console);
    logger->set_level(spdlog::level::warn);
    spdlog::set_default_logger(logger);
    return;
  }
  if (!earlier.empty()) { // what this run logged before its directory existed, first
    std::ofstream early(dir / "log.txt", append ? std::ios::app : std::ios::trunc);
    for (const auto& l : earlier) early << l;
    if (!early) throw std::runtime_error("cannot write " + (dir / "log.txt").string());
  }
  auto file = std::make_shared<spdlog::sinks::basic_file_sink_mt>((dir / "log.txt").string(),
                                                                  !append && earlier.empty());
  console->set_level(spdlog::level::info);
  auto logger = std::make_shared<spdlog::logger>("demfem", spdlog::sinks_init_list{console, file});
  logger->set_level(spdlog::level::debug);
  logger->flush_on(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

// load_or_report with --seed applied to the base scene and every variant.
scene::SceneFile load_for(const RunArgs& a, int& rc) {
  auto f = load_or_report(a.scene, rc);
  if (rc == kOk && a.seed >= 0) {
    f.base.info.seed = static_cast<unsigned long>(a.seed);
    for (auto& v : f.variants) v.info.seed = static_cast<unsigned long>(a.seed);
  }
  return f;
}

// A default output directory for a --seed run: its own seed-N subdirectory (so realisations do
// not share a run directory); an explicit --out is used as given.
fs::path with_seed_dir(fs::path out, const RunArgs& a) {
  if (a.seed >= 0 && a.out.empty()) out /= fmt::format("seed-{}", a.seed);
  return out;
}

std::vector<const scene::Scene*> pick(const scene::SceneFile& f, const RunArgs& a, int& rc) {
  std::vector<const scene::Scene*> out;
  rc = kOk;
  try {
    if (a.all_variants) {
      if (f.variants.empty()) out.push_back(&f.base);
      for (const auto& v : f.variants) out.push_back(&v);
    } else if (a.variants.empty()) {
      out.push_back(&f.base);
    } else {
      for (const auto& v : a.variants) out.push_back(&f.select(v));
    }
  } catch (const scene::SceneError& e) {
    fmt::print(stderr, "{}\n", e.what());
    rc = kBadInput;
  }
  return out;
}

struct SolverOutcome {
  bool ran = false; // false: not built or not listed by the scene
  bool ok = false;
  bool bad_input = false;   // the solver refused the scene (SceneError)
  bool interrupted = false; // stopped by a signal after writing a checkpoint
  std::string message;
  std::string note; // a successful run that ended early (e.g. a model validity limit)
};

// PNG: ends with its IEND chunk; SVG: with </svg>. A figure cut short by a full disk or a file size
// limit fails both.
bool image_complete(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  if (!in) return false;
  in.seekg(0, std::ios::end);
  const auto size = static_cast<long long>(in.tellg());
  const long long tail = std::min<long long>(size, 64);
  std::string t(static_cast<std::size_t>(tail), '\0');
  in.seekg(size - tail);
  in.read(t.data(), tail);
  if (!in) return false;
  if (f.extension() == ".png")
    return size >= 12 &&
           t.compare(t.size() - 12, 12, std::string("\0\0\0\0IEND\xae\x42\x60\x82", 12)) == 0;
  if (f.extension() == ".svg") return t.find("</svg>") != std::string::npos;
  return size > 0;
}

// Every figure the run lists exists and is complete (with its SVG twin, when there is one), and
// gnuplot did not fail on any; else scene::WriteError naming the file.
void check_figures(const compare::RunFigures& f) {
  for (const auto& p : f.problems)
    if (p.find("gnuplot failed") != std::string::npos)
      throw scene::WriteError(fmt::format("figure not written: {} (set [output] figures = false "
                                          "to run without figures)",
                                          p));
  for (const auto& png : f.figures) {
    if (!image_complete(png))
      throw scene::WriteError(fmt::format(
          "cannot write {}: the figure is missing or cut short (a full disk or a file size limit?)",
          png.string()));
    auto svg = png;
    svg.replace_extension(".svg");
    if (fs::exists(svg) && !image_complete(svg))
      throw scene::WriteError(fmt::format(
          "cannot write {}: the figure is cut short (a full disk or a file size limit?)",
          svg.string()));
  }
}

// Runs one solver on one resolved scene into `out` (outputs under out/dem or out/continuum).
// Each run also records itself in out/run_<solver>.json (compare::SolverRun: outcome, the solver's
// own and the total wall time, steps, Δt, resolution), which the comparison report reads.
SolverOutcome run_solver(const scene::Scene& s, scene::Solver solver, const fs::path& out,
                         const RunArgs& a) {
  SolverOutcome r;
  const auto t0 = std::chrono::steady_clock::now();
  compare::SolverRun rec;
  rec.solver = solver == scene::Solver::Dem ? "dem" : "continuum";
  rec.threads = solver == scene::Solver::Dem ? a.threads : 1;
  bool root = true; // false on MPI ranks > 0 of a continuum run
  app::ProgressReporter reporter;
  const auto progress = [&](const scene::Progress& p) { reporter(p); };
  try {
    if (solver == scene::Solver::Dem) {
      dem::RunOptions o;
      o.out_dir = out;
      o.resume = a.resume;
      o.threads = a.threads;
      o.progress = progress;
      o.interrupt = &g_interrupt;
      const auto x = dem::run(s, o);
      r.ran = true;
      r.ok = x.ok;
      r.interrupted = x.interrupted;
      r.message = x.message;
      rec.solver_seconds = x.wall_seconds;
      rec.steps = x.steps;
      rec.dt = x.dt;
      rec.simulated_time = x.simulated_time;
      rec.particles = x.particles;
      if (x.ok && s.output.figures) { // issue 4: the run's figures and summary.json
        const auto f = compare::write_run_figures(s, out, x.wall_seconds, x.steps);
        for (const auto& p : f.problems) spdlog::warn("figure: {}", p);
        check_figures(f);
        spdlog::info("{}: {} figure(s) in {}, {}", s.label(), f.figures.size(),
                     (out / "figures").string(), f.summary.string());
      }
    } else {
#ifdef DEMFEM_WITH_CONTINUUM
      continuum::RunOptions o;
      o.out_dir = out;
      o.refinement = a.refinement;
      o.degree = a.degree;
      o.progress = progress;
      const auto x = app::continuum_module().run(s, o);
      r.ran = true;
      r.ok = x.ok;
      r.message = x.message;
      r.note = x.note;
      rec.solver_seconds = x.wall_seconds;
      rec.steps = x.steps;
      rec.dt = x.dt;
      rec.simulated_time = x.simulated_time;
      rec.dofs = x.dofs;
      rec.cells = x.cells;
      rec.refinement = x.refinement;
      rec.degree = x.degree;
      rec.integrator = x.integrator;
      rec.substeps = x.substeps;
      rec.h_min = x.h_min;
      rec.h_max = x.h_max;
      rec.seated = x.seated;
      root = x.root;
      if (!x.note.empty()) spdlog::warn("{}: continuum: {}", s.label(), x.note);
#else
      r.message = "the continuum solver is not in this build (-DDEMFEM_WITH_CONTINUUM=OFF)";
#endif
    }
  } catch (const scene::SceneError& e) {
    r.ran = true;
    r.bad_input = true;
    r.message = e.what();
  } catch (const std::exception& e) { // a failed write (naming the file and the cause), …
    r.ran = true;
    r.ok = false;
    r.message = e.what();
  }
  reporter.finish();
  if (r.ran && !r.bad_input && !r.interrupted && root) { // (MPI: rank 0 writes it)
    rec.ok = r.ok;
    rec.message = r.message;
    rec.note = r.note;
    rec.total_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    try {
      compare::write_solver_run(out, rec);
    } catch (const std::exception& e) {
      spdlog::warn("{}: {}", s.label(), e.what()); // the run's results stand without it
    }
  }
  return r;
}

using compare::shell_quote;

// The command that continues an interrupted run of one scene (variant) in `out`.
std::string resume_command(const char* sub, const scene::Scene& s, const fs::path& out,
                           const RunArgs& a) {
  std::string c = fmt::format("demfem {} {}", sub, shell_quote(a.scene));
  if (std::string(sub) == "run" && a.solver != "dem") c += " --solver " + shell_quote(a.solver);
  if (!s.variant.empty()) c += " --variant " + shell_quote(s.variant);
  c += " --out " + shell_quote(out.string());
  if (a.threads != 1) c += fmt::format(" --threads {}", a.threads);
  return c + " --resume";
}

// Logs the stop and how to continue; returns kInterrupted.
int report_interrupted(const char* sub, const scene::Scene& s, const fs::path& out,
                       const RunArgs& a, const std::string& message) {
  spdlog::warn("{}: stopped by {}: {}", s.label(), signal_name(g_signal), message);
  spdlog::warn("{}: checkpoint {}; continue with:\n  {}", s.label(),
               (out / "dem" / "checkpoint.ckpt").string(), resume_command(sub, s, out, a));
  return kInterrupted;
}

fs::path run_dir_for(const scene::Scene& s, const RunArgs& a, std::size_t count) {
  fs::path out = a.out.empty() ? fs::path("runs") / s.info.name : fs::path(a.out);
  if (count > 1 || (!s.variant.empty() && a.out.empty()))
    out /= s.variant.empty() ? "base" : s.variant;
  return with_seed_dir(out, a);
}

// The identity of a run directory: the scene as given (variant applied, before the calibration
// fills in the continuum), hashed. A DEM run, which does not calibrate, and a continuum run,
// which does, of the same scene share a directory; another scene does not. Written as a comment
// line of scene.resolved.toml.
constexpr std::string_view kIdentityTag = "# scene identity: ";
std::string scene_identity(const scene::Scene& given) {
  dem::KeyHash h;
  std::istringstream in(scene::to_toml(given));
  for (std::string l; std::getline(in, l);)
    if (l.rfind('#', 0) != 0) h.str(l); // the header names the file; the scene is the rest
  return fmt::format("{}{:016x}", kIdentityTag, h.h);
}

// Creates the run directory, writes scene.resolved.toml and opens log.txt. Returns kOk, or
// kRunFailed with a message naming the directory or file and the cause (e.g. an unwritable --out).
int start_run_dir(const scene::Scene& s, const scene::Scene& given, const fs::path& out,
                  bool resume) {
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) {
    fmt::print(stderr, "demfem: cannot create the run directory {}: {}\n", out.string(),
               ec.message());
    return kRunFailed;
  }
  try {
    std::string text = scene::to_toml(s);
    text.insert(text.find('\n') + 1,
                scene_identity(given) +
                    " (the scene before calibration; a run into this directory must have it)\n");
    scene::write_file_atomic(out / "scene.resolved.toml", text);
    setup_run_log(out, resume);
  } catch (const std::exception& e) {
    fmt::print(stderr, "demfem: cannot write into the run directory {}: {}\n", out.string(),
               e.what());
    return kRunFailed;
  }
  return kOk;
}

// `demfem calibrate` (issue 9): DEM element tests → calibration.json, calibration.toml, figures.
struct CalibrateArgs {
  int particles = 1000;
  int specimens = compare::CalibrateOptions{}.specimens;
  std::vector<double> depths = compare::CalibrateOptions{}.depth_fractions;
  bool cyclic = true;
  bool force = false;
};
int cmd_calibrate(const RunArgs& a, const CalibrateArgs& ca) {
  int rc = kOk;
  const auto file = load_for(a, rc);
  if (rc != kOk) return rc;
  const auto scenes = pick(file, a, rc);
  if (rc != kOk) return rc;
  for (const scene::Scene* s : scenes) {
    fs::path out =
        a.out.empty() ? fs::path("runs") / s->info.name / "calibration" : fs::path(a.out);
    if (scenes.size() > 1 || (!s->variant.empty() && a.out.empty()))
      out /= s->variant.empty() ? "base" : s->variant;
    out = with_seed_dir(out, a);
    compare::CalibrateOptions o;
    o.out_dir = out;
    o.particles = ca.particles;
    o.specimens = ca.specimens;
    o.depth_fractions = ca.depths;
    o.cyclic = ca.cyclic;
    app::ProgressReporter reporter;
    o.progress = [&](const scene::Progress& p) { reporter(p); };
    try {
      const auto c = ca.force ? compare::calibrate(*s, o) : compare::load_or_calibrate(*s, o);
      reporter.finish();
      const auto files = compare::write_calibration(c, out, true);
      fmt::print("{}: calibration {} ({}, {:.1f} s when computed)\n", s->label(), c.key,
                 c.from_cache ? "found in the cache" : "computed", c.wall_seconds);
      fmt::print("  bed: porosity {:.4f}, bulk density {:.5g} kg/m³, K0 {:.3f}, surface {:.4g} m "
                 "(mass-matched; mean column top {:.4g} m)\n",
                 c.porosity, c.bulk_density, c.k0, c.surface, c.surface_top_mean);
      for (const auto& t : c.tests)
        fmt::print("  biaxial σ_c = {:8.4g} kPa, specimen {}: φ_peak {:5.1f}°  φ_cv {:5.1f}°  ψ "
                   "{:5.1f}°  E50' {:.3g} MPa  ν' {:.3f}  n {:.4f}{}\n",
                   t.sigma_c / 1e3, t.specimen + 1, t.phi_peak, t.phi_cv, t.psi, t.e50 / 1e6,
                   t.nu_inplane, t.porosity, t.failure.empty() ? "" : "  FAILED: " + t.failure);
      fmt::print("  envelope ({} specimen(s)): φ {:.2f}°, c {:.4g} kPa; affine E' {:.3g} MPa, G "
                 "{:.3g} MPa\n",
                 c.specimens, c.phi_fit, c.cohesion_fit / 1e3, c.affine_e / 1e6, c.affine_g / 1e6);
      for (std::size_t k = 0; k < c.specimen_fits.size(); ++k)
        fmt::print("    specimen {} (seed {}) alone: φ {:.2f}°, c {:.4g} kPa\n", k + 1,
                   k < c.specimen_seeds.size() ? c.specimen_seeds[k] : 0ul,
                   c.specimen_fits[k].first, c.specimen_fits[k].second / 1e3);
      for (const auto& p : c.cyclic)
        fmt::print("  cyclic γ = {:.3g}: G {:.3g} MPa, ξ {:.1f} %, ν' {:.3f}\n", p.gamma, p.g / 1e6,
                   100.0 * p.xi, p.nu);
      fmt::print("{}", compare::continuum_block(c));
      for (const auto& f : files.written) fmt::print("  wrote {}\n", f.string());
      for (const auto& p : files.problems) fmt::print(stderr, "figure: {}\n", p);
    } catch (const scene::SceneError& e) {
      reporter.finish();
      fmt::print(stderr, "{}\n", e.what());
      return kBadInput;
    }
  }
  return kOk;
}

// [soil.continuum] calibrate = "dem": the scene with the calibrated values filled in (computed,
// or read from the cache). Logs one line per key; `notes` gets them. `figures`: draw the
// calibration's figures into out/calibration even when it came from the cache (the comparison
// report embeds them); otherwise only when it was computed now.
// `compute` false (a DEM run, which reads no calibration): only a cached calibration is applied,
// for the record; none is made.
scene::Scene with_calibration(const scene::Scene& s, const fs::path& out,
                              std::vector<std::string>* notes = nullptr, bool figures = false,
                              bool compute = true) {
  scene::Scene r = s;
  if (!r.soil.continuum || !r.soil.continuum->calibrate_dem || !r.uses(scene::Solver::Continuum))
    return r;
  compare::CalibrateOptions o;
  o.out_dir = out / "calibration";
  if (!compute) {
    std::error_code ec;
    const fs::path f = compare::calibration_cache_dir(r, o) /
                       ("calibration-" + compare::calibration_key(r, o) + ".json");
    if (!fs::exists(f, ec)) {
      spdlog::info("{}: the continuum is not calibrated yet (a DEM run does not need it; the first "
                   "continuum run, `demfem compare` or `demfem calibrate` makes it)",
                   s.label());
      r.soil.continuum->provenance.emplace_back(
          "calibration", "not made by this DEM run: the [soil.continuum] values here are the "
                         "defaults, a continuum run fills them in");
      return r;
    }
  }
  app::ProgressReporter reporter;
  o.progress = [&](const scene::Progress& p) { reporter(p); };
  const auto c = compare::load_or_calibrate(s, o);
  reporter.finish();
  const auto files = compare::write_calibration(c, o.out_dir, figures || !c.from_cache);
  for (const auto& p : files.problems) spdlog::warn("calibration figure: {}", p);
  for (const auto& line : compare::apply_calibration(r, c)) {
    spdlog::info("{}: continuum {}", s.label(), line);
    if (notes) notes->push_back("Continuum " + line);
  }
  return r;
}

// --report-only: the scene with the calibration its run used (<out>/calibration/calibration.json)
// applied, without computing anything; the scene as is when there is none.
scene::Scene calibration_of_run(const scene::Scene& s, const fs::path& out) {
  scene::Scene r = s;
  const fs::path f = out / "calibration" / "calibration.json";
  if (!r.soil.continuum || !r.soil.continuum->calibrate_dem || !fs::is_regular_file(f)) return r;
  try {
    compare::apply_calibration(r, compare::read_calibration(f));
  } catch (const std::exception& e) {
    spdlog::warn("{}: {} unreadable ({}); the report shows the scene's values", s.label(),
                 f.string(), e.what());
    return s;
  }
  return r;
}

// `demfem compare` as the user would type it again for this run directory.
std::string reproduce_command(const scene::Scene& s, const fs::path& out, const RunArgs& a) {
  std::string c = "demfem compare " + shell_quote(a.scene);
  if (!s.variant.empty()) c += " --variant " + shell_quote(s.variant);
  if (!a.out.empty()) c += " --out " + shell_quote(out.string());
  if (a.threads != 1) c += fmt::format(" --threads {}", a.threads);
  if (a.refinement >= 0) c += fmt::format(" --refinement {}", a.refinement);
  if (a.degree >= 1) c += fmt::format(" --degree {}", a.degree);
  if (a.seed >= 0) c += fmt::format(" --seed {}", a.seed);
  return c;
}

// What the solvers, figures and report write into a run directory (what --force clears).
constexpr const char* kRunOutputs[] = {"dem",          "continuum",         "figures",
                                       "summary.json", "report.html",       "metrics.json",
                                       "run_dem.json", "run_continuum.json"};

// The resolved scene without its comment lines (they name the file it came from).
std::vector<std::string> scene_lines(const std::string& toml) {
  std::vector<std::string> lines;
  std::istringstream in(toml);
  for (std::string l; std::getline(in, l);)
    if (l.rfind('#', 0) != 0) lines.push_back(l);
  return lines;
}

void remove_outputs(const fs::path& out, const std::vector<std::string>& names) {
  // Under an MPI launcher every rank runs this command; only the first clears (the others write
  // nothing into the run directory): two ranks clearing at once made the slower one fail with
  // "cannot clear …/continuum: No such file or directory" (exit 1) on a re-run into a used
  // directory with mpirun -np 2.
  if (compare::study_rank() != 0) return;
  for (const auto& n : names) {
    std::error_code ec;
    fs::remove_all(out / n, ec);
    if (ec)
      throw std::runtime_error(
          fmt::format("cannot clear {}: {}", (out / n).string(), ec.message()));
  }
}

// Before a run writes into `out`: a directory holding another scene's results (its
// scene.resolved.toml differs, or it has solver outputs and no scene.resolved.toml) is refused
// unless --force, which clears every solver output first. A fresh run of the same scene clears
// the outputs it is about to write (`fresh`), so figures and summaries are built only from files
// this run wrote; --resume keeps them. Returns kOk or kBadInput (message printed).
int prepare_run_dir(const scene::Scene& s, const scene::Scene& given, const fs::path& out,
                    const RunArgs& a, const char* sub, const std::vector<std::string>& fresh) {
  if (a.resume || !fs::exists(out)) return kOk;
  const fs::path resolved = out / "scene.resolved.toml";
  std::string why;
  if (fs::exists(resolved)) {
    std::ifstream in(resolved);
    std::stringstream ss;
    ss << in.rdbuf();
    const auto old_lines = scene_lines(ss.str()), new_lines = scene_lines(scene::to_toml(s));
    // The directory's identity (scene_identity) when it records one; else, from an older demfem,
    // the resolved scenes themselves.
    const std::string id = scene_identity(given);
    std::string old_id;
    {
      std::istringstream t(ss.str());
      for (std::string l; std::getline(t, l);)
        if (l.starts_with(kIdentityTag)) old_id = l.substr(0, id.size());
    }
    if (old_id.empty() ? old_lines != new_lines : old_id != id) {
      std::size_t i = 0;
      while (i < old_lines.size() && i < new_lines.size() && old_lines[i] == new_lines[i]) ++i;
      // "# resolved scene: <label> (from <file>)", the first line to_toml writes
      std::string label = ss.str().substr(0, ss.str().find('\n'));
      const std::string tag = "# resolved scene: ";
      label = label.rfind(tag, 0) == 0
                  ? label.substr(tag.size(), label.rfind(" (from") - tag.size())
                  : std::string("?");
      why = fmt::format("{} is scene '{}' (first difference: `{}` there, `{}` here)",
                        resolved.string(), label, i < old_lines.size() ? old_lines[i] : "",
                        i < new_lines.size() ? new_lines[i] : "");
    }
  } else {
    for (const char* n : {"dem", "continuum"})
      if (fs::exists(out / n) && why.empty())
        why = fmt::format("it holds {}/ but no scene.resolved.toml saying which scene wrote it",
                          (out / n).string());
  }
  if (!why.empty()) {
    if (!a.force) {
      fmt::print(stderr,
                 "demfem {}: {} holds the results of a different scene: {}. Nothing was run. Use "
                 "another --out, or --force to clear its results ({}) first.\n",
                 sub, out.string(), why, fmt::join(kRunOutputs, ", "));
      return kBadInput;
    }
    fmt::print(stderr, "demfem {}: --force: clearing the results of another scene in {} ({})\n",
               sub, out.string(), why);
    remove_outputs(out, {std::begin(kRunOutputs), std::end(kRunOutputs)});
  }
  remove_outputs(out, fresh);
  return kOk;
}

// The last non-empty line of a child's console log (what it said when it stopped).
std::string last_line(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

// run --jobs N (issue 12: the paper suite on 2 cores): the selected variants as separate
// `demfem run` processes, N at once (each with --threads as given, 1 by default), so a machine
// with N cores runs N variants where one run uses one core. The packings and calibrations the
// variants share are made once each (also N at once, before any run is started while one is left
// to start), so no two children build the same cache entry; each run starts once its own is made.
// Each child's console goes to <run dir>/console.txt; this process prints one line per finished
// child and returns 0 only when every child succeeded (else the first failing child's exit code).
int run_parallel(const std::vector<const scene::Scene*>& scenes, const RunArgs& a) {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) {
    fmt::print(stderr, "demfem run --jobs: cannot find its own binary (/proc/self/exe): {}\n",
               ec.message());
    return kRunFailed;
  }
  const bool continuum = a.solver == "continuum";
  std::vector<compare::ProcessTask> prep, runs;
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
  for (const scene::Scene* s : scenes) {
    const fs::path out = run_dir_for(*s, a, scenes.size());
    fs::create_directories(out, ec);
    if (ec) {
      fmt::print(stderr, "demfem: cannot create the run directory {}: {}\n", out.string(),
                 ec.message());
      return kRunFailed;
    }
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
      const std::string key = calibrated ? "calibration " + compare::calibration_key(*s, {})
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
    run_prep.push_back(needs);
    run_label.push_back(s->label());
    run_cost.push_back(continuum ? 0.0 : dem_work(*s, s->info.duration));
  }
  // Largest estimated work first (longest-processing-time order), ties in file order: the short
  // runs fill the end, where one core would otherwise idle while the last long run finishes.
  // Returns the new order (new position → old index).
  const auto largest_first = [&](std::vector<compare::ProcessTask>& tasks,
                                 std::vector<std::string>& labels, const std::vector<double>& cost,
                                 const char* what) {
    std::vector<std::size_t> order(tasks.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t x, std::size_t y) { return cost[x] > cost[y]; });
    bool moved = false;
    for (std::size_t k = 0; k < order.size(); ++k) moved = moved || order[k] != k;
    if (!moved) return order;
    std::vector<compare::ProcessTask> t;
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
  std::vector<compare::ProcessTask> tasks = std::move(prep);
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
  compare::run_processes(tasks, a.jobs, [&](std::size_t i, const compare::ProcessResult& r) {
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
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  fmt::print(stderr, "demfem run --jobs {}: {} run(s) in {:.1f} s{}\n", a.jobs, n_runs, total,
             first_failure == kOk ? "" : " — some FAILED (above)");
  return first_failure;
}

int cmd_run(const RunArgs& a) {
  int rc = kOk;
  const auto file = load_for(a, rc);
  if (rc != kOk) return rc;
  const auto scenes = pick(file, a, rc);
  if (rc != kOk) return rc;
  if (a.solver != "dem" && a.solver != "continuum") {
    fmt::print(stderr, "demfem run: unknown solver '{}'; valid: dem, continuum\n", a.solver);
    return kBadInput;
  }
  const scene::Solver solver = a.solver == "dem" ? scene::Solver::Dem : scene::Solver::Continuum;
#ifndef DEMFEM_WITH_CONTINUUM
  if (solver == scene::Solver::Continuum)
    return not_built("run --solver continuum",
                     "this binary was configured with -DDEMFEM_WITH_CONTINUUM=OFF");
#endif
  for (const scene::Scene* s : scenes)
    if (!s->uses(solver)) {
      fmt::print(stderr, "demfem run: scene '{}' does not list \"{}\" in scene.solvers\n",
                 s->label(), a.solver);
      return kBadInput;
    }
  if (a.jobs > 1 && scenes.size() > 1) return run_parallel(scenes, a);
  int worst = kOk;
  for (const scene::Scene* s : scenes) {
    log_before_run_dir();
    const fs::path out = run_dir_for(*s, a, scenes.size());
    // A continuum run calibrates (calibrate = "dem"); a DEM run records a cached calibration
    // only: it reads none, and its directory's identity is the scene before calibration.
    const scene::Scene sc =
        with_calibration(*s, out, nullptr, false, solver == scene::Solver::Continuum);
    if (const int p = prepare_run_dir(
            sc, *s, out, a, "run",
            solver == scene::Solver::Dem
                ? std::vector<std::string>{"dem", "figures", "summary.json", "run_dem.json"}
                : std::vector<std::string>{"continuum", "run_continuum.json"});
        p != kOk)
      return p;
    if (const int d = start_run_dir(sc, *s, out, a.resume); d != kOk) return d;
    spdlog::info("demfem {}: {} with the {} solver → {}", DEMFEM_VERSION, s->label(), a.solver,
                 out.string());
    const auto r = run_solver(sc, solver, out, a);
    if (r.bad_input) {
      fmt::print(stderr, "{}\n", r.message);
      return kBadInput;
    }
    if (r.interrupted) return report_interrupted("run", *s, out, a, r.message);
    if (r.ok) {
      spdlog::info("{}: done; outputs in {}", s->label(), out.string());
    } else {
      spdlog::error("{}: run failed: {}", s->label(), r.message);
      worst = kRunFailed;
    }
  }
  return worst;
}

int compare_ensemble(const RunArgs& a);

// Both solvers on the same scene, then the comparison report.
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
    std::vector<std::string> calibrated;
    const scene::Scene cs = a.report_only ? calibration_of_run(*s0, out)
                                          : with_calibration(*s0, out, &calibrated, true);
    const scene::Scene* s = &cs; // issue 9: calibrate = "dem" resolved
    if (a.report_only) {
      if (!fs::is_directory(out)) {
        fmt::print(stderr, "demfem compare --report-only: no run directory {}\n", out.string());
        return kBadInput;
      }
    } else {
      if (const int p = prepare_run_dir(*s, *s0, out, a, "compare",
                                        {std::begin(kRunOutputs), std::end(kRunOutputs)});
          p != kOk)
        return p;
      if (const int d = start_run_dir(*s, *s0, out, a.resume); d != kOk) return d;
    }
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
    bool any_ok = false;
    for (const auto solver : {scene::Solver::Dem, scene::Solver::Continuum}) {
      const char* name = solver == scene::Solver::Dem ? "dem" : "continuum";
      if (a.report_only) {
        any_ok = any_ok || fs::is_directory(out / name);
        continue;
      }
      if (!s->uses(solver)) {
        ro.notes.push_back(fmt::format("The scene does not list \"{}\" in scene.solvers.", name));
        continue;
      }
      spdlog::info("demfem {}: {} with the {} solver → {}", DEMFEM_VERSION, s->label(), name,
                   out.string());
      const auto r = run_solver(*s, solver, out, a);
      if (r.bad_input) {
        fmt::print(stderr, "{}\n", r.message);
        return kBadInput;
      }
      if (r.interrupted) return report_interrupted("compare", *s, out, a, r.message);
      if (r.ok) {
        any_ok = true;
        if (!r.note.empty()) ro.notes.push_back(fmt::format("The {} run {}.", name, r.note));
      } else {
        ro.notes.push_back(
            fmt::format("The {} solver {}: {}", name, r.ran ? "failed" : "did not run", r.message));
        spdlog::error("{}: {} solver: {}", s->label(), name, r.message);
      }
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
    if (!any_ok) worst = kRunFailed;
  }
  return worst;
}

// compare --seeds (issue 9): one comparison per packing seed into <run dir>/seed-N (each a
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
    std::vector<compare::EnsembleMember> members;
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
    auto e = compare::summarise_ensemble(members);
    // the command that runs the ensemble (--report-only rebuilds it: not the way to reproduce it)
    const std::string command =
        reproduce_command(*s, dir, a) + fmt::format(" --seeds {}", fmt::join(a.seeds, ","));
    try {
      const auto files = compare::write_ensemble(
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

// `demfem pack`: deposit (or find in the cache) the packing of each chosen scene (issue 4).
int cmd_pack(const RunArgs& a) {
  int rc = kOk;
  const auto file = load_for(a, rc);
  if (rc != kOk) return rc;
  const auto scenes = pick(file, a, rc);
  if (rc != kOk) return rc;
  int worst = kOk;
  for (const scene::Scene* s : scenes) {
    if (!s->soil.dem) {
      fmt::print(stderr, "demfem pack: scene '{}' has no [soil.dem]\n", s->label());
      return kBadInput;
    }
    fs::path out = a.out.empty() ? fs::path("runs") / s->info.name : fs::path(a.out);
    if (scenes.size() > 1 || (!s->variant.empty() && a.out.empty()))
      out /= s->variant.empty() ? "base" : s->variant;
    out = with_seed_dir(out, a);
    app::ProgressReporter reporter;
    try {
      const auto r = dem::pack_or_load(*s, out, [&](const scene::Progress& p) { reporter(p); });
      reporter.finish();
      fmt::print(
          "{}: {} particles, {} {} (deposition {:.3g} s simulated, {} steps, KE/PE {:.2e}{}, "
          "{} layer(s), {:.1f} s wall), surface top {:.4g} m\n",
          s->label(), r.particles.size(), r.from_cache ? "found in the cache" : "packed into",
          r.path.string(), r.deposition_time, r.steps, r.ke_ratio,
          r.converged ? "" : " — stopped at packing.max_time", r.layers, r.wall_seconds,
          r.surface_max);
      const auto& pk = s->soil.dem->packing;
      fmt::print("  porosity {:.4f} (void ratio {:.4f}, window z {:.4g}–{:.4g} m), coordination "
                 "number {:.3f}, rattlers {:.1f} %{}\n",
                 r.measure.porosity, r.measure.void_ratio, r.measure.z_bottom, r.measure.z_top,
                 r.measure.coordination, 100.0 * r.measure.rattlers,
                 pk.target_porosity
                     ? fmt::format("; target porosity {:.4f} ± {:.4f}: {} (friction × {:.4g} "
                                   "during deposition, {} deposition(s))",
                                   *pk.target_porosity, pk.target_tolerance,
                                   r.target_met ? "met" : "NOT MET", r.friction_scale, r.trials)
                     : std::string());
      if (r.carved > 0)
        fmt::print("  {} particles carved out where embedded structures stand (deposited without "
                   "them, then settled around them)\n",
                   r.carved);
      if (pk.target_porosity && !r.target_met && !a.target_not_met_ok) worst = kRunFailed;
    } catch (const scene::SceneError& e) {
      reporter.finish();
      fmt::print(stderr, "{}\n", e.what());
      return kBadInput;
    }
  }
  return worst;
}

// The resolved scene as "section.key = value" entries (a continuation line of a multi-line
// value is appended to its entry), for the variant summary of `check`.
std::vector<std::pair<std::string, std::string>> flatten_toml(const std::string& text) {
  std::vector<std::pair<std::string, std::string>> out;
  std::string section;
  std::map<std::string, int> tables;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::string t = line.substr(first);
    const bool header =
        t.front() == '[' && t.back() == ']' &&
        t.find_first_not_of("[]._-abcdefghijklmnopqrstuvwxyz0123456789") == std::string::npos;
    if (header) { // [a.b] or [[a]] (the k-th entry of an array of tables: a[k])
      const bool array = t.starts_with("[[");
      std::string name = t;
      std::erase(name, '[');
      std::erase(name, ']');
      section = array ? fmt::format("{}[{}]", name, tables[name]++) : name;
      continue;
    }
    const auto eq = line.find(" = ");
    if (eq != std::string::npos && line.find_first_of("[{\"") > eq) {
      out.emplace_back((section.empty() ? "" : section + ".") + line.substr(first, eq - first),
                       line.substr(eq + 3));
    } else if (!out.empty()) {
      out.back().second += line.substr(first);
    }
  }
  // Inline tables { a = 1, b = [ 2, 3 ] } → one entry per member (key.a, key.b).
  std::vector<std::pair<std::string, std::string>> flat;
  for (auto& [k, v] : out) {
    if (v.size() < 2 || v.front() != '{' || v.back() != '}' ||
        v.find('{', 1) != std::string::npos) {
      flat.emplace_back(k, v);
      continue;
    }
    int depth = 0;
    std::size_t start = 1;
    for (std::size_t i = 1; i < v.size(); ++i) {
      const char c = v[i];
      if (c == '[' || c == '{') ++depth;
      if ((c == ']' || c == '}') && depth > 0 && i + 1 < v.size()) --depth;
      if ((c == ',' && depth == 0) || i + 1 == v.size()) {
        std::string m = v.substr(start, i - start);
        const auto a = m.find_first_not_of(' '), e = m.find(" = ");
        if (a != std::string::npos && e != std::string::npos) {
          std::string val = m.substr(e + 3);
          while (!val.empty() && val.back() == ' ') val.pop_back();
          flat.emplace_back(k + "." + m.substr(a, e - a), val);
        }
        start = i + 1;
      }
    }
  }
  return flat;
}

// One line per scene: what it is, and for a variant what it changes against the base scene.
void print_summary(const scene::SceneFile& file) {
  const auto& b = file.base;
  const auto solvers = [](const scene::Scene& s) {
    std::vector<std::string> v;
    if (s.uses(scene::Solver::Dem)) v.emplace_back("dem");
    if (s.uses(scene::Solver::Continuum)) v.emplace_back("continuum");
    return fmt::format("{}", fmt::join(v, "+"));
  };
  fmt::print("{} — {}\n  base: {}, {} s{}, {} wall(s), {} structure(s)\n", b.info.name,
             b.info.description, solvers(b), b.info.duration,
             b.soil.dem ? fmt::format(", {} particles", b.soil.dem->count) : std::string(),
             b.walls.size(), b.structures.size());
  const auto base = flatten_toml(scene::to_toml(b));
  const std::map<std::string, std::string> base_map(base.begin(), base.end());
  const auto shorten = [](const std::string& s) {
    return s.size() > 40 ? s.substr(0, 37) + "…" : s;
  };
  for (const auto& v : file.variants) {
    std::vector<std::string> changes;
    for (const auto& [k, val] : flatten_toml(scene::to_toml(v))) {
      const auto it = base_map.find(k);
      const std::string was = it == base_map.end() ? "(none)" : it->second;
      if (was != val) changes.push_back(fmt::format("{} {} → {}", k, shorten(was), shorten(val)));
    }
    fmt::print("  {:<22} {}{}{}\n", v.variant, v.variant_description,
               v.variant_description.empty() ? "" : " — ",
               changes.empty() ? std::string("(no change)")
                               : fmt::format("{}", fmt::join(changes, "; ")));
  }
  fmt::print("  (`demfem check --resolved` prints every resolved value)\n");
}

int cmd_check(const std::string& path, bool quiet, bool resolved) {
  int rc = kOk;
  const auto file = load_or_report(path, rc);
  if (rc != kOk) return rc;
  if (!quiet && !resolved) print_summary(file);
  if (!quiet && resolved) {
    fmt::print("{}", scene::to_toml(file.base));
    for (const auto& v : file.variants) {
      fmt::print("\n# ===== variant {} =====\n", v.variant);
      fmt::print("{}", scene::to_toml(v));
    }
  }
  fmt::print(
      stderr, "{}: OK ({} variant(s){})\n", path, file.variants.size(),
      file.variants.empty() ? "" : ": " + fmt::format("{}", fmt::join(file.variant_names(), ", ")));
  return kOk;
}

// `demfem study error-vs-time SCENE` (issue 11 item 1): resolution sweeps, each run a separate
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
  compare::ErrorStudyOptions o;
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
  app::ProgressReporter reporter;
  o.progress = [&](const scene::Progress& p) { reporter(p); };
  if (path == "flamant") {
#ifndef DEMFEM_WITH_CONTINUUM
    fmt::print(stderr, "demfem study error-vs-time flamant: the continuum solver is not in this "
                       "build (-DDEMFEM_WITH_CONTINUUM=OFF)\n");
    return kBadInput;
#else
    o.out_dir =
        a.out.empty() ? fs::path("runs") / "flamant" / "study-error-vs-time" : fs::path(a.out);
    o.out_dir = fs::absolute(o.out_dir);
    if (compare::study_rank() == 0) setup_run_log(o.out_dir, false);
    const auto st = compare::flamant_error_study(o);
    if (compare::study_rank() == 0) compare::write_error_study(st, o.out_dir);
    compare::finish_study_ranks(o.out_dir);
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
    const bool closed = compare::head_on_closed_form(*s, &why).has_value();
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
    fs::path out =
        a.out.empty() ? fs::path("runs") / s->info.name / "study-error-vs-time" : fs::path(a.out);
    if (scenes.size() > 1 || (!s->variant.empty() && a.out.empty()))
      out /= s->variant.empty() ? "base" : s->variant;
    o.out_dir = fs::absolute(out);
    // under mpirun the runs are spread over the ranks; rank 0 keeps the log and writes the study
    if (compare::study_rank() == 0) setup_run_log(o.out_dir, false);
    if (compare::study_ranks() > 1)
      spdlog::info("study rank {} of {}: runs every {}th setting", compare::study_rank(),
                   compare::study_ranks(), compare::study_ranks());
    compare::ErrorStudy st;
    if (closed) {
      st = compare::dem_error_study(*s, o);
    } else {
      // No closed form (issue 11): every solver against its most resolved run. The calibration
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
        st = compare::scene_error_study(*s, o);
      } catch (const scene::SceneError& e) {
        fmt::print(stderr, "{}\n", e.what());
        return kBadInput;
      }
    }
    if (compare::study_rank() == 0) compare::write_error_study(st, o.out_dir);
    compare::finish_study_ranks(o.out_dir);
    if (compare::study_rank() != 0) continue;
    for (const auto& f : st.fits)
      spdlog::info("{} {} against {}: order {:.3f} ({} points)", f.knob, f.metric, f.against,
                   f.order, f.points);
    spdlog::info("{}: error-vs-time study in {}", s->label(), (o.out_dir / "study.html").string());
  }
  return kOk;
}

// `demfem study-point dem|flamant …`: one run of an error-vs-time study as its own process (hidden
// from --help); writes its result and the solver's own wall time as JSON.
struct PointArgs {
  std::string problem, scene, out, json;
  int refinement = 0, degree = 2;
};
int cmd_study_point(const PointArgs& pa) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto seconds = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  if (pa.problem == "dem") {
    int rc = kOk;
    const auto file = load_or_report(pa.scene, rc);
    if (rc != kOk) return rc;
    setup_run_log(pa.out, false);
    dem::RunOptions o;
    o.out_dir = pa.out;
    o.threads = 1;
    const auto x = dem::run(file.base, o);
    scene::write_file_atomic(
        pa.json, fmt::format("{{\"solver_seconds\": {:.9g}, \"process_seconds\": {:.9g}, "
                             "\"steps\": {}, \"dt\": {:.17g}, \"ok\": {}}}\n",
                             x.wall_seconds, seconds(), x.steps, x.dt, x.ok));
    if (!x.ok) fmt::print(stderr, "{}\n", x.message);
    return x.ok ? kOk : kRunFailed;
  }
  if (pa.problem == "continuum") {
#ifdef DEMFEM_WITH_CONTINUUM
    int rc = kOk;
    const auto file = load_or_report(pa.scene, rc);
    if (rc != kOk) return rc;
    setup_run_log(pa.out, false);
    // calibrate = "dem": read from the cache (the study computed it before starting the runs)
    const scene::Scene sc = with_calibration(file.base, pa.out);
    continuum::RunOptions o;
    o.out_dir = pa.out;
    const auto x = app::continuum_module().run(sc, o);
    scene::write_file_atomic(
        pa.json,
        fmt::format("{{\"solver_seconds\": {:.9g}, \"process_seconds\": {:.9g}, "
                    "\"steps\": {}, \"dt\": {:.17g}, \"dofs\": {}, \"h_min\": "
                    "{:.17g}, \"integrator\": \"{}\", \"ok\": {}}}\n",
                    x.wall_seconds, seconds(), x.steps, x.dt, x.dofs, x.h_min, x.integrator, x.ok));
    if (!x.ok) fmt::print(stderr, "{}\n", x.message);
    return x.ok ? kOk : kRunFailed;
#else
    fmt::print(stderr, "demfem study-point: the continuum solver is not in this build\n");
    return kBadInput;
#endif
  }
  if (pa.problem != "flamant") {
    fmt::print(stderr,
               "demfem study-point: unknown problem '{}'; valid: dem, continuum, "
               "flamant\n",
               pa.problem);
    return kBadInput;
  }
#ifdef DEMFEM_WITH_CONTINUUM
  const auto r = app::continuum_module().flamant_strip_load(pa.refinement, pa.degree);
  scene::write_file_atomic(
      pa.json, fmt::format("{{\"computed\": {:.17g}, \"exact\": {:.17g}, \"dofs\": {}, "
                           "\"h_min\": {:.17g}, \"converged\": {}, \"solver_seconds\": "
                           "{:.9g}}}\n",
                           r.computed, r.exact, r.dofs, r.h_min, r.converged, seconds()));
  return r.converged ? kOk : kRunFailed;
#else
  fmt::print(stderr, "demfem study-point: the continuum solver is not in this build\n");
  return kBadInput;
#endif
}

// `demfem study stability SCENE` (issue 11): the DEM rows of the stability matrix.
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
    fs::path out =
        a.out.empty() ? fs::path("runs") / s->info.name / "study-stability" : fs::path(a.out);
    if (scenes.size() > 1 || (!s->variant.empty() && a.out.empty()))
      out /= s->variant.empty() ? "base" : s->variant;
    setup_run_log(out, false);
    compare::StudyOptions o;
    o.out_dir = out;
    o.threads = a.threads;
    o.repack = repack;
    if (duration > 0.0) o.duration = duration;
#ifdef DEMFEM_WITH_CONTINUUM
    if (cont)
      o.continuum_rows = [&out](const scene::Scene& sc0) {
        const auto& cm = app::continuum_module(); // opens the module (throws when it cannot)
        std::vector<compare::StabilityRow> rows;
        const auto add = [&rows](const continuum::StabilityCase& c) {
          compare::StabilityRow r;
          r.solver = "continuum";
          r.name = c.name;
          r.description = c.description;
          r.outcome = c.outcome;
          r.cause = c.cause;
          r.measure = c.measure;
          r.iterations = c.newton_iterations;
          r.residuals = c.residuals;
          r.steps = c.load_steps;
          r.wall_seconds = c.wall_seconds;
          spdlog::info("continuum {:<22} {:<10} {} {}", c.name, c.outcome, c.measure, c.cause);
          rows.push_back(r);
          return c.value;
        };
        const int degree = std::max(1, sc0.continuum.degree);
        // ν → 0.5: locking shown by the rocking stiffness without B-bar against the B-bar run
        for (const double nu : {0.49, 0.499}) {
          const double kb = add(cm.rocking_locking_case(nu, true, degree));
          const double kn = add(cm.rocking_locking_case(nu, false, degree));
          if (std::isfinite(kb) && std::isfinite(kn) && kb > 0.0)
            rows.back().measure += fmt::format("; {:.4f} × the B-bar run (locking)", kn / kb);
        }
        add(cm.stiff_structure_case(1.0e6, degree));
        // the scene's own continuum (calibrated moduli) for the explicit step guard
        const scene::Scene sc = with_calibration(sc0, out);
        // ν → 0.5 on the scene's own mesh and seating: the seated settlement without B-bar
        // against the B-bar row (no closed form there: the built-in rows above carry it)
        for (const double nu : {0.49, 0.499}) {
          const double wb = add(cm.scene_locking_case(sc, nu, true));
          const double wn = add(cm.scene_locking_case(sc, nu, false));
          if (std::isfinite(wb) && std::isfinite(wn) && wb != 0.0)
            rows.back().measure +=
                fmt::format("; settlement {:.4f} × the B-bar run's (locking)", wn / wb);
        }
        add(cm.explicit_step_case(sc, 1.5));
        for (const double f : {0.9, 1.1}) add(cm.bearing_capacity_case(f, degree));
        return rows;
      };
#endif
    const auto rows = compare::stability_study(*s, o);
    compare::write_stability_study(rows, *s, out);
    for (const auto& r : rows) spdlog::info("{:<22} {:<15} {}", r.name, r.outcome, r.cause);
    spdlog::info("{}: stability study in {}", s->label(), (out / "study.html").string());
  }
  return kOk;
}

} // namespace

int main(int argc, char** argv) {
  dem::keep_freed_memory_for_reuse(); // the neighbour rebuilds' lists (malloc_tuning.hpp)
  CLI::App app{"demfem — the same geotechnical scene as a granular assembly (DEM) and as a "
               "continuum (FEM), and where the two diverge."};
  app.footer(kExitCodes);
  // The engine fingerprint (dem/pack.hpp): which DEM, bit for bit, made a run's packings.
  app.set_version_flag("--version", [] {
    return fmt::format("demfem {}\nDEM engine fingerprint {}", DEMFEM_VERSION,
                       dem::engine_fingerprint());
  });
  app.require_subcommand(1);

  RunArgs ra;
  auto* run = app.add_subcommand("run", "Run one solver on a scene (or some of its variants).");
  run->add_option("scene", ra.scene, "Scene file (TOML)")->required()->check(CLI::ExistingFile);
  run->add_option("--solver", ra.solver, "dem or continuum")->default_val("dem");
  run->add_option("--variant", ra.variants, "Variant name (repeatable); default: the base scene");
  run->add_flag("--all-variants", ra.all_variants, "Run every [[variant]] of the file");
  run->add_option("--out", ra.out, "Run directory (default runs/<scene>[/<variant>])");
  run->add_flag("--resume", ra.resume, "Continue from the last checkpoint in the run directory");
  run->add_flag("--force", ra.force,
                "Run into a directory that holds another scene's results, clearing them first");
  run->add_option("--seed", ra.seed,
                  "Packing seed (scene.seed) instead of the file's; default directory gains "
                  "seed-N")
      ->check(CLI::NonNegativeNumber);
  run->add_option(
         "--threads", ra.threads,
         "DEM OpenMP threads (0 = all cores; results are bit-reproducible for a given count)")
      ->default_val(1)
      ->check(CLI::NonNegativeNumber);
  run->add_option("--jobs", ra.jobs,
                  "With several variants: run N of them at once, as separate processes (shared "
                  "packings and calibrations are made first, once each, and a run starts as soon "
                  "as its own is made; the largest estimated work starts first); each child's "
                  "console goes to <run dir>/console.txt")
      ->default_val(1)
      ->check(CLI::PositiveNumber);
  run->add_option("--refinement", ra.refinement,
                  "Continuum: global refinement level (overrides the scene)");
  run->add_option("--degree", ra.degree, "Continuum: polynomial degree (overrides the scene)");
  run->footer(kExitCodes);

  std::string check_path;
  bool quiet = false;
  auto* check =
      app.add_subcommand("check", "Validate a scene file (all its variants) and summarise it, one "
                                  "line per variant, or list its errors with file:line:column.");
  check->add_option("scene", check_path, "Scene file (TOML)")->required();
  check->add_flag("-q,--quiet", quiet, "Only report OK or the errors");
  bool resolved = false;
  check->add_flag("--resolved", resolved,
                  "Print the whole resolved scene (all variants) instead of the summary");
  check->footer(kExitCodes);

  std::string other_scene;
  auto* compare = app.add_subcommand("compare", "Run DEM and continuum on the same scene and write "
                                                "report.html and metrics.json comparing every "
                                                "quantity both wrote.");
  compare->add_option("scene", ra.scene, "Scene file")->required()->check(CLI::ExistingFile);
  compare->add_option("--variant", ra.variants, "Variant name");
  compare->add_flag("--all-variants", ra.all_variants, "All variants");
  compare->add_option("--out", ra.out, "Run directory (default runs/<scene>[/<variant>])");
  compare->add_flag("--resume", ra.resume, "DEM: continue from the last checkpoint");
  compare->add_flag("--force", ra.force,
                    "Run into a directory that holds another scene's results, clearing them first");
  compare->add_flag("--report-only", ra.report_only,
                    "Run nothing: rewrite report.html and metrics.json from the run directory");
  compare->add_option("--threads", ra.threads, "DEM OpenMP threads (0 = all cores)")
      ->default_val(1)
      ->check(CLI::NonNegativeNumber);
  compare->add_option("--refinement", ra.refinement, "Continuum: refinement level");
  compare->add_option("--degree", ra.degree, "Continuum: polynomial degree");
  compare->add_option("--seed", ra.seed, "Packing seed (scene.seed) instead of the file's")
      ->check(CLI::NonNegativeNumber);
  compare
      ->add_option("--seeds", ra.seeds,
                   "Seed ensemble: one comparison per packing seed into <out>/seed-N, then "
                   "ensemble.html and ensemble.json (e.g. --seeds 41,101,202)")
      ->delimiter(',');
  compare->footer(kExitCodes);
  std::string study_kind;
  double study_duration = 0.0;
  bool study_repack = false;
  ErrorStudyArgs ea;
  auto* study = app.add_subcommand(
      "study", "stability: stiff and extreme variants (DEM rows; continuum rows for scenes with "
               "a continuum) → study.json, study.md, study.html. error-vs-time: resolution "
               "sweeps against a closed form or the most resolved run, each run a "
               "separate process (repeated), fitted orders, error against wall time with the "
               "Pareto front → study.json, study.md, study.html, figures/.");
  study->add_option("kind", study_kind, "stability | error-vs-time")->required();
  study
      ->add_option("scene", other_scene,
                   "Scene file; for error-vs-time also `flamant` (built-in Flamant strip load, "
                   "continuum)")
      ->required();
  study->add_option("--variant", ra.variants, "Variant name (repeatable); default: the base scene");
  study->add_option("--out", ra.out,
                    "Output directory (default runs/<scene>/study-stability or "
                    "runs/<scene>/study-error-vs-time)");
  study
      ->add_option("--duration", study_duration,
                   "stability, and error-vs-time on a scene without a closed form: simulated "
                   "time of every run [s] (default: the scene's)")
      ->check(CLI::PositiveNumber);
  study
      ->add_option("--solver", ea.solver,
                   "error-vs-time on a scene without a closed form: dem | continuum | both "
                   "(default both: those the scene lists)")
      ->default_val("both");
  study
      ->add_option("--integrators", ea.integrators,
                   "error-vs-time, continuum: explicit,implicit (default: the scene's, then the "
                   "other)")
      ->delimiter(',');
  study
      ->add_option("--kn-packing", ea.kn_packing,
                   "error-vs-time on a packed scene: the K_n settings start from the scene's "
                   "packing (same) or each deposit their own (deposit)")
      ->default_val("same")
      ->check(CLI::IsMember({"same", "deposit"}));
  study
      ->add_option("--max-run-seconds", ea.max_run_seconds,
                   "error-vs-time on a scene: a run past this is stopped and the finer settings "
                   "of its knob skipped (listed in the study) [s]; 0 = no limit")
      ->default_val(300.0)
      ->check(CLI::NonNegativeNumber);
  study->add_flag("--repack", study_repack,
                  "stability, packed scenes: deposit the packing of every row whose soil "
                  "parameters change (default: such rows are skipped unless their packing is "
                  "cached)");
  study->add_option("--threads", ra.threads, "stability: DEM OpenMP threads (0 = all cores)")
      ->check(CLI::NonNegativeNumber);
  study->add_option("--jobs", ea.jobs, "error-vs-time: runs at once (separate processes)")
      ->default_val(1)
      ->check(CLI::Range(1, 256));
  study->add_option("--repeats", ea.repeats, "error-vs-time: runs per setting (timings)")
      ->default_val(3)
      ->check(CLI::Range(1, 100));
  study
      ->add_option("--dt-fractions", ea.dt_fractions,
                   "error-vs-time, DEM: Δt as fractions of the critical step (default 1/4 … "
                   "1/1024, halving; scenes without a closed form 0.5,0.25,0.125)")
      ->delimiter(',')
      ->check(CLI::Range(1e-9, 1.0));
  study
      ->add_option("--kn-factors", ea.kn_factors,
                   "error-vs-time, DEM: K_n multipliers, automatic Δt (default 0.1,0.3,1,3,10; "
                   "scenes without a closed form 0.3,1,3)")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  // multiplier lists that also take "none" (the knob off); absent: the study's defaults
  const auto factor_list = [&study](const char* name, std::optional<std::vector<double>>& to,
                                    const std::string& help) {
    study->add_option_function<std::string>(
        name, [&to, name](const std::string& v) { to = parse_factor_list(v, name); }, help);
  };
  factor_list("--size-factors", ea.size_factors,
              "error-vs-time on a packed scene, DEM: particle count multipliers at fixed "
              "geometry (count × f, radii / √f, each its own packing; default 1,4; none = off)");
  factor_list("--near-factors", ea.near_factors,
              "error-vs-time on a scene with a graded continuum mesh: mesh_size_near multipliers "
              "at the scene's refinement (default 2,1,0.5; none = off)");
  factor_list("--continuum-dt-factors", ea.cont_dt_factors,
              "error-vs-time on a scene, continuum: time step multipliers on the sweep's coarsest "
              "mesh (explicit: of the automatic step; implicit: of the Newmark step; default "
              "1,0.5,0.25; none = off)");
  study
      ->add_option("--refinements", ea.refinements,
                   "error-vs-time, continuum: refinement levels (flamant default 1,2,3,4; a "
                   "scene: its refinement − 2 … its refinement)")
      ->delimiter(',')
      ->check(CLI::Range(0, 8));
  study
      ->add_option("--degrees", ea.degrees,
                   "error-vs-time, continuum: polynomial degrees (default 1,2)")
      ->delimiter(',')
      ->check(CLI::Range(1, 4));
  study->footer(kExitCodes);
  PointArgs pa;
  auto* study_point = app.add_subcommand("study-point", "One run of an error-vs-time study");
  study_point->group(""); // hidden: the study starts it as its own process
  study_point->add_option("problem", pa.problem, "dem | continuum | flamant")->required();
  study_point->add_option("--scene", pa.scene, "dem, continuum: resolved scene file");
  study_point->add_option("--out", pa.out, "dem, continuum: run directory");
  study_point->add_option("--refinement", pa.refinement, "flamant: refinement");
  study_point->add_option("--degree", pa.degree, "flamant: degree");
  study_point->add_option("--json", pa.json, "Result file")->required();
  CalibrateArgs ca;
  auto* calibrate = app.add_subcommand(
      "calibrate", "Continuum parameters from DEM element tests (biaxial, cyclic) on specimens "
                   "of the scene's packing, and the deposited bed's density, K0 and surface; "
                   "writes calibration.json, calibration.toml and figures (cached).");
  calibrate->add_option("scene", ra.scene, "Scene file")->required()->check(CLI::ExistingFile);
  calibrate->add_option("--variant", ra.variants, "Variant name (repeatable)");
  calibrate->add_option("--out", ra.out, "Output directory (default runs/<scene>/calibration)");
  calibrate->add_option("--particles", ca.particles, "Specimen size (disks)")
      ->default_val(1000)
      ->check(CLI::Range(50, 100000));
  calibrate
      ->add_option("--specimens", ca.specimens,
                   "Specimen realisations, each tested at every confinement (the envelope "
                   "is fitted to all of them)")
      ->capture_default_str()
      ->check(CLI::Range(1, 20));
  calibrate
      ->add_option("--depths", ca.depths,
                   "Confinements σ_c = ρ_b g z at these fractions of the bed height "
                   "(comma-separated)")
      ->delimiter(',')
      ->capture_default_str()
      ->check(CLI::Range(0.01, 1.0));
  calibrate->add_flag("!--no-cyclic", ca.cyclic, "Skip the cyclic tests (G/G0, damping)");
  calibrate->add_flag("--force", ca.force, "Recompute even when the calibration is cached");
  calibrate->add_option("--seed", ra.seed, "Packing seed (scene.seed) instead of the file's")
      ->check(CLI::NonNegativeNumber);
  calibrate->footer(kExitCodes);
  auto* pack = app.add_subcommand("pack", "Deposit the scene's particles and save the packing "
                                          "(reused from the cache when it exists).");
  pack->add_option("scene", ra.scene, "Scene file")->required()->check(CLI::ExistingFile);
  pack->add_option("--variant", ra.variants, "Variant name (repeatable); default: the base scene");
  pack->add_flag("--all-variants", ra.all_variants, "Every [[variant]] of the file");
  pack->add_option("--out", ra.out,
                   "Run directory (default runs/<scene>[/<variant>]); the "
                   "packing goes to packing.cache or <out>/packing");
  pack->add_option("--seed", ra.seed, "Packing seed (scene.seed) instead of the file's")
      ->check(CLI::NonNegativeNumber);
  pack->add_flag("--target-not-met-ok", ra.target_not_met_ok,
                 "Exit 0 when a porosity target is not met (the packing nearest to it is kept, and "
                 "a run uses it and says so; run --jobs prepares packings this way)");
  pack->footer(kExitCodes);

  install_stop_signals();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kBadInput;
  }

  // Under an MPI launcher every rank runs the command: the console and log messages come from
  // the first rank only (each line was printed once per rank; setup_run_log too); warnings and
  // errors from all. `study` spreads its settings over the ranks, and each says what it runs.
  if (compare::study_rank() != 0 && !*study) spdlog::set_level(spdlog::level::warn);
  try {
    if (*run) return cmd_run(ra);
    if (*check) return cmd_check(check_path, quiet, resolved);
    if (*compare) return cmd_compare(ra);
    if (*study) return cmd_study(study_kind, other_scene, ra, study_duration, ea, study_repack);
    if (*study_point) return cmd_study_point(pa);
    if (*calibrate) return cmd_calibrate(ra, ca);
    if (*pack) return cmd_pack(ra);
  } catch (const std::exception& e) {
    fmt::print(stderr, "demfem: error: {}\n", e.what());
    return kRunFailed;
  }
  return kBadInput;
}
