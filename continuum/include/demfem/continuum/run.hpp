// Entry point of the continuum (FEM) solver for the app. No deal.II type crosses this header.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "demfem/scene/progress.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::continuum {

struct RunOptions {
  std::filesystem::path out_dir; // run directory; continuum outputs go to out_dir/"continuum"
  int refinement = -1;           // -1 = the scene's
  int degree = -1;               // -1 = the scene's
  scene::ProgressFn progress;
};

struct RunSummary {
  bool ok = false;
  std::string message;
  std::string note; // e.g. the run stopped early at the small-strain validity limit
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
};

RunSummary run(const scene::Scene& scene, const RunOptions& options);

} // namespace demfem::continuum
