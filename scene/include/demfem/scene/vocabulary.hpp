// The vocabulary a scene file is read with: the models the program knows (chosen by keyword, each
// reading its own keys: params.hpp) and the stable time-step limits the solvers compute. scene/
// knows neither the models nor the solvers; the caller passes them in, so that every program that
// loads a scene (demfem, the tests, the fuzzers) validates it the same way. The full vocabulary is
// app::vocabulary() (app/include/demfem/app/vocabulary.hpp); dem::vocabulary() is the DEM's part.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "demfem/scene/params.hpp"

namespace demfem::scene {

struct Scene;

// The DEM's stable time-step limit of a scene (dem/stable_step.hpp: pair reduced mass,
// shear–rotation mode, coordination, damping). With it, loading a scene refuses an explicit
// soil.dem.dt above the limit at the dt key's file:line:col, exactly as `run` would, and the
// automatic step is dt_safety × the limit.
struct DemStepLimit {
  double dt = 0.0;     // the limit [s]
  std::string formula; // how it was obtained, for messages
};

// The continuum's explicit stable step of a scene: explicit_safety × the critical
// central-difference step of its mesh (continuum/README.md); nothing when the scene's moduli are
// not known yet (calibrate = "dem" without a cached calibration). With it, loading a scene refuses
// an explicit-integrator continuum.dt above it at the dt key's file:line:col, and the continuum
// run refuses the same step with the same message (continuum_step_refusal, validate.hpp).
struct ContinuumStepLimit {
  double dt = 0.0;     // the stable step [s] (explicit_safety × the critical step)
  std::string formula; // how it was obtained (mesh, moduli), for messages
};

struct Vocabulary {
  // [soil.dem]: the slots of the DEM soil (the contact law, rolling resistance), read in order
  std::vector<ModelSlot> dem;
  // [soil.continuum]: the slots of the continuum soil (its constitutive model)
  std::vector<ModelSlot> continuum;
  // Unset: the check is not made (a program without that solver).
  std::function<std::optional<DemStepLimit>(const Scene&)> dem_step_limit;
  std::function<std::optional<ContinuumStepLimit>(const Scene&)> continuum_step_limit;
};

} // namespace demfem::scene
