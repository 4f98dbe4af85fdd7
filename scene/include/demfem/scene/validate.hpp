// Semantic validation of a resolved scene: what a scene says must be possible before any
// computation starts. load_scene_file() runs it on the base scene and on every variant, with the
// step limits of the vocabulary it is given (vocabulary.hpp), so `check` and every command refuse
// the same scenes, with file:line:col, before a run directory exists.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "demfem/scene/load.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::scene {

// Ceilings: a scene above one of them is refused (exit 2) with the estimate and the reason.
inline constexpr double kMaxSteps = 1e9;              // DEM steps (deposition + run) per scene
inline constexpr double kMaxMemoryBytes = 64e9;       // estimated DEM memory
inline constexpr double kMaxOutputBytes = 1e12;       // estimated snapshot + time-series output
inline constexpr double kMaxPackingFraction = 0.9069; // π/(2√3): densest disk packing (Thue)
inline constexpr double kBytesPerParticle = 1024.0;   // state, neighbour lists, contact history
inline constexpr double kSnapshotBytesPerParticle = 160.0; // particles + force chains (.vtp)

// The message for a step above the limit (shared by the scene check and the DEM engine).
[[nodiscard]] std::string dem_step_refusal(double dt, const DemStepLimit& limit, double auto_dt);

// The message for an explicit continuum step above the stable step.
[[nodiscard]] std::string continuum_step_refusal(double dt, const ContinuumStepLimit& limit);
// The Diagnostic for it, located at the scene's continuum.dt (scene.source_file, dt_line/column).
[[nodiscard]] Diagnostic continuum_step_diagnostic(const Scene& scene,
                                                   const ContinuumStepLimit& limit);

struct Estimates {
  // DEM (only when the scene has [soil.dem]):
  double solid_area = 0.0;       // Σ πr² over the expected radii [m²]
  double available_area = 0.0;   // domain area minus the structures inside it [m²]
  double packing_fraction = 0.0; // solid_area / available_area
  std::optional<double> dt;      // the DEM step [s] (given, or the automatic one); unset: unknown
  bool dt_automatic = false;
  std::optional<DemStepLimit> dt_limit; // the stable limit, when the vocabulary has one
  double steps = 0.0;                   // duration / dt
  double packing_steps = 0.0; // packing.max_time / dt (at most; 0 with explicit particles)
  double memory_bytes = 0.0;
  double snapshots = 0.0;    // duration / output.interval + 1
  double output_bytes = 0.0; // snapshots and time series
  double series_bytes = 0.0; // the time series' part of it
};

[[nodiscard]] Estimates estimate(const Scene& scene, const Vocabulary& vocabulary);

} // namespace demfem::scene
