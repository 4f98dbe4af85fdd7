// Semantic validation of a resolved scene (issue 13): what a scene says must be possible before
// any computation starts. load_scene_file() runs it on the base scene and on every variant, so
// `check` and every command refuse the same scenes, with file:line:col, before a run directory
// exists. The estimates are also printed by `demfem check`.
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

// The DEM's stable time-step limit of a scene, computed by the DEM layer (dem/stable_step.hpp:
// pair reduced mass, shear–rotation mode, coordination, damping), which scene/ does not link.
// The application installs it at start-up (app/src/main.cpp); then load_scene_file() refuses an
// explicit soil.dem.dt above the limit at the dt key's file:line:col, exactly as `run` would, and
// the automatic step is dt_safety × the limit. Not installed (scene-only tools): neither.
struct DemStepLimit {
  double dt = 0.0;     // the limit [s]
  std::string formula; // how it was obtained, for messages
};
using DemStepLimitFn = std::optional<DemStepLimit> (*)(const Scene&);
void set_dem_step_limit(DemStepLimitFn fn);
// The message for a step above the limit (shared by the scene check and the DEM engine).
[[nodiscard]] std::string dem_step_refusal(double dt, const DemStepLimit& limit, double auto_dt);

// The continuum's explicit stable step of a scene (issue 10/11): explicit_safety × the critical
// central-difference step of its mesh (continuum/README.md), computed by the continuum layer,
// which scene/ does not link. Installed by the application (app/src/main.cpp) when the continuum
// is built; it returns nothing when the scene's moduli are not known yet (calibrate = "dem"
// without a cached calibration). Then load_scene_file() refuses an explicit-integrator
// continuum.dt above it at the dt key's file:line:col, and the continuum run refuses the same
// step with the same message (continuum_step_refusal) at the same place.
struct ContinuumStepLimit {
  double dt = 0.0;     // the stable step [s] (explicit_safety × the critical step)
  std::string formula; // how it was obtained (mesh, moduli), for messages
};
using ContinuumStepLimitFn = std::optional<ContinuumStepLimit> (*)(const Scene&);
void set_continuum_step_limit(ContinuumStepLimitFn fn);
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
  std::optional<DemStepLimit> dt_limit; // the stable limit, when the DEM layer is installed
  double steps = 0.0;                   // duration / dt
  double packing_steps = 0.0; // packing.max_time / dt (at most; 0 with explicit particles)
  double memory_bytes = 0.0;
  double snapshots = 0.0;    // duration / output.interval + 1
  double output_bytes = 0.0; // snapshots and time series
  double series_bytes = 0.0; // the time series' part of it
};

[[nodiscard]] Estimates estimate(const Scene& scene);

} // namespace demfem::scene
