// Entry point of the DEM engine for the app: run one resolved scene into a run directory.
#pragma once

#include <atomic>
#include <filesystem>
#include <string>

#include "demfem/scene/progress.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::dem {

struct RunOptions {
  std::filesystem::path out_dir; // run directory (created); DEM outputs go to out_dir/"dem"
  bool resume = false;           // continue from out_dir/dem/checkpoint.ckpt (bit for bit)
  int threads = 0;               // 0 = OpenMP default
  // When it becomes true the loop writes out_dir/dem/checkpoint.ckpt and returns ok = false
  // with "interrupted at t = … s; continue with --resume". May be null.
  std::atomic<bool>* interrupt = nullptr;
  scene::ProgressFn progress; // may be empty
};

struct RunSummary {
  bool ok = false;
  bool interrupted = false; // stopped by options.interrupt after writing checkpoint.ckpt
  std::string message;      // failure cause (blow-up: step, time, particle, cause)
  long long steps = 0;
  double simulated_time = 0.0;
  double wall_seconds = 0.0;
  std::size_t particles = 0;
  double dt = 0.0;                // the step used [s] (0: refused before it was set)
  double closure_error = 0.0;     // end-of-run |imbalance| / energy put in (energy_watch.cpp)
  double max_overlap_ratio = 0.0; // largest δ/r seen at the probes (r the smaller radius)
  std::size_t particles_left_unplanned = 0; // left while no wall was open (kFlagLeftUnplanned)
};

// Runs the scene's DEM model. Throws scene::SceneError for a scene the engine cannot build
// (e.g. a time step above the stable limit); returns ok = false when the run itself fails.
RunSummary run(const scene::Scene& scene, const RunOptions& options);

} // namespace demfem::dem
