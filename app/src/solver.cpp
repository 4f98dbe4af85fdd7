#include "solver.hpp"

#include <algorithm>
#include <chrono>
#include <fstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "command.hpp"
#include "demfem/compare/figures.hpp"
#include "demfem/compare/model_differences.hpp"
#include "demfem/compare/report.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/scene/write_file.hpp"
#include "progress.hpp"
#include "signals.hpp"
#ifdef DEMFEM_WITH_CONTINUUM
#include "continuum_module.hpp"
#endif

namespace fs = std::filesystem;

namespace demfem::app {

namespace {

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

// The command that continues an interrupted run of one scene (variant) in `out`.
std::string resume_command(const char* sub, const scene::Scene& s, const fs::path& out,
                           const RunArgs& a) {
  using compare::shell_quote;
  std::string c = fmt::format("demfem {} {}", sub, shell_quote(a.scene));
  if (std::string(sub) == "run" && a.solver != "dem") c += " --solver " + shell_quote(a.solver);
  if (!s.variant.empty()) c += " --variant " + shell_quote(s.variant);
  c += " --out " + shell_quote(out.string());
  if (a.threads != 1) c += fmt::format(" --threads {}", a.threads);
  if (a.refinement >= 0) c += fmt::format(" --refinement {}", a.refinement);
  if (a.degree >= 0) c += fmt::format(" --degree {}", a.degree);
  if (a.seed >= 0) c += fmt::format(" --seed {}", a.seed);
  return c + " --resume";
}

} // namespace

SolverOutcome run_solver(const scene::Scene& s, scene::Solver solver, const fs::path& out,
                         const RunArgs& a) {
  SolverOutcome r;
  const auto t0 = std::chrono::steady_clock::now();
  compare::SolverRun rec;
  rec.solver = solver == scene::Solver::Dem ? "dem" : "continuum";
  rec.threads = solver == scene::Solver::Dem ? a.threads : 1;
  bool root = true; // false on MPI ranks > 0 of a continuum run
  ProgressReporter reporter;
  const auto progress = [&](const scene::Progress& p) { reporter(p); };
  try {
    if (solver == scene::Solver::Dem) {
      dem::RunOptions o;
      o.out_dir = out;
      o.resume = a.resume;
      o.threads = a.threads;
      o.progress = progress;
      o.interrupt = &stop_requested();
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
      if (x.ok && s.output.figures) { // the run's figures and summary.json
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
      // a stop signal ends the run after its current step (the explicit integrator writes its
      // checkpoint first)
      o.resume = a.resume;
      o.interrupt = &stop_requested();
      const auto x = continuum_module().run(s, o);
      if (!x.resume_note.empty()) spdlog::warn("{}: --resume: {}", s.label(), x.resume_note);
      r.ran = true;
      r.ok = x.ok;
      r.interrupted = x.interrupted;
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
      // the record is an output: the report's run times and "what differs" come from it
      r.ok = false;
      r.message = e.what();
    }
  }
  return r;
}

int report_interrupted(const char* sub, const scene::Scene& s, scene::Solver solver,
                       const fs::path& out, const RunArgs& a, const std::string& message) {
  spdlog::warn("{}: stopped by {}: {}", s.label(), stop_signal_name(), message);
  if (solver == scene::Solver::Dem) {
    spdlog::warn("{}: checkpoint {}; continue with:\n  {}", s.label(),
                 (out / "dem" / "checkpoint.ckpt").string(), resume_command(sub, s, out, a));
    return kInterrupted;
  }
  if (s.continuum.integrator == "explicit") {
    spdlog::warn("{}: checkpoint {}; continue with:\n  {}", s.label(),
                 (out / "continuum" / "checkpoint.ckpt").string(), resume_command(sub, s, out, a));
    return kInterrupted;
  }
  std::string again = resume_command(sub, s, out, a);
  if (std::string(sub) == "run") again.resize(again.size() - std::string(" --resume").size());
  spdlog::warn("{}: the implicit continuum run cannot resume (the implicit integrator writes no "
               "checkpoint): its outputs in {} stop at the time it reached; {}:\n  {}",
               s.label(), (out / "continuum").string(),
               std::string(sub) == "run" ? "run it again from the start"
                                         : "continue (the DEM's results are kept, the continuum "
                                           "starts over) with",
               again);
  return kInterrupted;
}

} // namespace demfem::app
