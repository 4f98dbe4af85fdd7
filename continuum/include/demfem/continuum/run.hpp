// Entry point of the continuum (FEM) solver for the app. No deal.II type crosses this header.
#pragma once

#include <atomic>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "demfem/scene/progress.hpp"
#include "demfem/scene/scene.hpp"
#include "demfem/scene/validate.hpp"

namespace demfem::continuum {

struct RunOptions {
  std::filesystem::path out_dir; // run directory; continuum outputs go to out_dir/"continuum"
  int refinement = -1;           // -1 = the scene's
  int degree = -1;               // -1 = the scene's
  scene::ProgressFn progress;
  // Continue from out_dir/continuum/checkpoint.ckpt (explicit integrator; bit for bit). With no
  // checkpoint there (none written yet, or the implicit integrator, which writes none) the run
  // starts from t = 0 and says so in RunSummary::resume_note.
  bool resume = false;
  // When it becomes true (on any MPI rank) the run stops after its current step, every rank after
  // the same one; the explicit integrator writes its checkpoint first. May be null.
  const std::atomic<bool>* interrupt = nullptr;
};

struct RunSummary {
  bool ok = false;
  bool interrupted = false; // stopped by RunOptions::interrupt (explicit: after its checkpoint)
  std::string message;
  std::string resume_note; // a --resume that starts from t = 0, and why
  std::string note;        // e.g. the run stopped early at the small-strain validity limit
  long long steps = 0;
  double simulated_time = 0.0;
  double wall_seconds = 0.0;
  std::size_t dofs = 0;
  // What was run, for the comparison report's "what differs" table (compare/report.hpp):
  std::size_t cells = 0;
  int refinement = 0, degree = 0;
  std::string integrator;          // "implicit" | "explicit"
  double dt = 0.0;                 // time step [s] (explicit: the central-difference step)
  long long substeps = 0;          // explicit: central-difference steps taken
  double h_min = 0.0, h_max = 0.0; // cell sizes [m] (coarse grid steps / 2^refinement)
  std::vector<std::pair<std::string, double>> seated; // (structure, settlement [m]) when seated
  // the static stage before t = 0 (gravity, K0 state, seating): Newton iterations in all and
  // the final relative residual
  int setup_newton_iterations = 0;
  double setup_residual = 0.0;
  bool root = true; // this process is MPI rank 0 (writes the run's shared records)
};

// An explicit-integrator continuum.dt above the stable step is refused with scene::SceneError
// located at the scene's continuum.dt (as the scene check refuses it), before any computation.
RunSummary run(const scene::Scene& scene, const RunOptions& options);

// The explicit integrator's automatic step for the scene (explicit_safety × the critical step of
// its mesh, from the moduli the scene states: apply a calibration first), with how it was
// obtained; nothing when the scene cannot be meshed. Builds the mesh only (no K0 procedure).
std::optional<scene::ContinuumStepLimit> stable_step(const scene::Scene& scene,
                                                     const RunOptions& options = {});

} // namespace demfem::continuum
