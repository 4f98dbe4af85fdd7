// `demfem run SCENE`: one solver on a scene, or on some of its variants.
#include <memory>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "calibration.hpp"
#include "command.hpp"
#include "log.hpp"
#include "run_dir.hpp"
#include "run_jobs.hpp"
#include "scenes.hpp"
#include "solver.hpp"
#include "thread_cap.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

namespace {

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
  if (solver == scene::Solver::Continuum) {
    fmt::print(stderr, "demfem run --solver continuum: not built yet (this binary was configured "
                       "with -DDEMFEM_WITH_CONTINUUM=OFF). Nothing was run.\n");
    return kBadInput;
  }
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
    Ownership own; // the run directory's lock, held until this run ends
    RunDirUse use;
    use.dem = solver == scene::Solver::Dem;
    use.continuum = !use.dem;
    if (const int p = open_run_dir(*s, out, a, use, own); p != kOk) return p;
    // A continuum run calibrates (calibrate = "dem"); a DEM run records a cached calibration
    // only: it reads none, and its directory's identity is the scene before calibration.
    const scene::Scene sc =
        with_calibration(*s, out, nullptr, false, solver == scene::Solver::Continuum);
    if (const int d = start_run_dir(sc, *s, out, a.resume); d != kOk) return d;
    spdlog::info("demfem {}: {} with the {} solver → {}", DEMFEM_VERSION, s->label(), a.solver,
                 out.string());
    const auto r = run_solver(sc, solver, out, a);
    if (r.bad_input) {
      fmt::print(stderr, "{}\n", r.message);
      return kBadInput;
    }
    if (r.interrupted) return report_interrupted("run", *s, solver, out, a, r.message);
    if (r.ok) {
      spdlog::info("{}: done; outputs in {}", s->label(), out.string());
    } else {
      spdlog::error("{}: run failed: {}", s->label(), r.message);
      worst = kRunFailed;
    }
  }
  return worst;
}

[[maybe_unused]] const bool registered = register_command(
    {"run", "Run one solver on a scene (or some of its variants).", 10, false,
     [](CLI::App&, CLI::App& sub) -> std::function<int()> {
       auto ra = std::make_shared<RunArgs>();
       sub.add_option("scene", ra->scene, "Scene file (TOML)")
           ->required()
           ->check(CLI::ExistingFile);
       sub.add_option("--solver", ra->solver, "dem or continuum")->default_val("dem");
       sub.add_option("--variant", ra->variants,
                      "Variant name (repeatable); default: the base scene");
       sub.add_flag("--all-variants", ra->all_variants, "Run every [[variant]] of the file");
       sub.add_option("--out", ra->out, "Run directory (default runs/<scene>[/<variant>])");
       sub.add_flag("--resume", ra->resume,
                    "Continue from the last checkpoint in the run directory");
       sub.add_flag("--force", ra->force,
                    "Run into a run directory that holds another scene's results, clearing the "
                    "results demfem wrote there first (a folder demfem did not make is never "
                    "cleared)");
       sub.add_option("--seed", ra->seed,
                      "Packing seed (scene.seed) instead of the file's; default directory gains "
                      "seed-N")
           ->check(CLI::Range(0LL, 2147483647LL)); // scene.seed's range
       sub.add_option(
              "--threads", ra->threads,
              "DEM OpenMP threads (0 = all cores; results are bit-reproducible for a given count)")
           ->default_val(1)
           ->check(CLI::NonNegativeNumber)
           ->transform(threads_capped_at_cores());
       sub.add_option("--jobs", ra->jobs,
                      "With several variants: run N of them at once, as separate processes "
                      "(shared packings and calibrations are made first, once each, and a run "
                      "starts as soon as its own is made; the largest estimated work starts "
                      "first); each child's console goes to <run dir>/console.txt")
           ->default_val(1)
           ->check(CLI::PositiveNumber);
       sub.add_option("--refinement", ra->refinement,
                      "Continuum: global refinement level (overrides the scene)");
       sub.add_option("--degree", ra->degree, "Continuum: polynomial degree (overrides the scene)");
       return [ra] { return cmd_run(*ra); };
     }});

} // namespace

} // namespace demfem::app
