// One solver run on one resolved scene into a run directory, as run and compare start it.
#pragma once

#include <filesystem>
#include <string>

#include "demfem/scene/scene.hpp"
#include "scenes.hpp"

namespace demfem::app {

struct SolverOutcome {
  bool ran = false; // false: not built or not listed by the scene
  bool ok = false;
  bool bad_input = false;   // the solver refused the scene (SceneError)
  bool interrupted = false; // stopped by a signal after writing a checkpoint
  std::string message;
  std::string note; // a successful run that ended early (e.g. a model validity limit)
};

// Runs one solver on one resolved scene into `out` (outputs under out/dem or out/continuum), with
// the DEM run's figures and summary.json. Each run also records itself in out/run_<solver>.json
// (compare::SolverRun: outcome, the solver's own and the total wall time, steps, Δt,
// resolution), which the comparison report reads; failing to write it fails the run.
SolverOutcome run_solver(const scene::Scene& s, scene::Solver solver,
                         const std::filesystem::path& out, const RunArgs& a);

// Logs the stop of `solver` and the command that continues the run of `sub` ("run" or "compare")
// in `out` (the DEM and the explicit continuum from their checkpoints; the implicit continuum,
// which has none, from the start); returns kInterrupted.
int report_interrupted(const char* sub, const scene::Scene& s, scene::Solver solver,
                       const std::filesystem::path& out, const RunArgs& a,
                       const std::string& message);

} // namespace demfem::app
