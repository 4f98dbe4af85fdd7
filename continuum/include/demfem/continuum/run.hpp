// Entry point of the continuum (FEM) solver for the app. No deal.II type crosses this header.
#pragma once

#include <filesystem>
#include <string>

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
};

RunSummary run(const scene::Scene& scene, const RunOptions& options);

} // namespace demfem::continuum
