// The DEM's stable time step: the largest Δt for which the symplectic Euler
// integrator (paper eqs. 2.16–2.18) stays bounded on the linearised contact network, with the
// pair's reduced mass, the shear–rotation mode of a pair, a margin for coordination, and the
// dashpots and global damping. One formula for `demfem check` (scene level, from the radius
// distribution), for `run` and `pack` (engine level, from the particles actually built) and for
// the automatic step (dt_safety × this bound). Derivation: stable_step.cpp.
#pragma once

#include <optional>
#include <string>

#include "demfem/scene/scene.hpp"
#include "demfem/scene/validate.hpp"

namespace demfem::dem {

struct EngineConfig;
class Engine;

// What the bound needs: the contact law's stiffnesses and damping ratio for a pair of the
// smallest particles (StepStiffness, from the law itself: dem/contact/), global damping and
// the smallest particle.
struct StepParams {
  double kn = 0.0, ks = 0.0;               // contact stiffnesses [N/m]
  double xi = 0.0;                         // the contact's damping ratio
  double kr = 0.0;                         // rolling spring [N·m/rad] (0: none)
  double damping_c = 0.0, damping_d = 0.0; // global damping [1/s]
  double m_min = 0.0;                      // mass of the smallest particle [kg]
  double r_min = 0.0;                      // its radius [m]
  double inertia_factor = 0.5;             // I/(m r²): ½ disk, 2/5 sphere
};

struct StepBound {
  double dt = 0.0;             // critical step [s] (+inf when no particle or no stiffness)
  double omega_pair = 0.0;     // stiffest mode of one contact between two smallest particles
  double omega_max = 0.0;      // with the coordination margin [rad/s]
  double omega_rolling = 0.0;  // the rolling spring's pair mode √(2k_r/I_min) (0: none) [rad/s]
  double damping_factor = 1.0; // √(1 + ξ²) − ξ
  bool shear_mode = false;     // the pair's stiffest mode is shear–rotation, not normal
  double kn = 0.0, ks = 0.0;   // stiffnesses used (Hertz: tangent at 5 % overlap) [N/m]
  // e.g. "2/ω_max, ω_max² = 4·max(2k_n, 6k_s)/m_min (shear–rotation mode)"
  [[nodiscard]] std::string formula() const;
};

// The coordination margin C = ω_max²/ω_pair² (see stable_step.cpp): max(4, 6g/(1 + g)),
// g = m r²/I.
[[nodiscard]] double coordination_margin(double inertia_factor);

[[nodiscard]] StepBound critical_step(const StepParams& p);
// Engine level: the engine's configuration and its smallest particle.
[[nodiscard]] StepParams step_params(const EngineConfig& c, double m_min, double r_min);
// Scene level: the smallest radius the scene can produce (listed particles or the radius
// distribution's lower end). Empty without [soil.dem] or without a radius.
[[nodiscard]] std::optional<StepBound> scene_critical_step(const scene::Scene& scene);
// Smallest radius of the scene's particles (listed, or the distribution's smallest), 0 if none.
[[nodiscard]] double scene_min_radius(const scene::DemSoil& d);
// scene_critical_step as the vocabulary's DEM step limit (vocabulary.hpp): loading a scene checks
// soil.dem.dt against this bound (scene/validate.hpp).
[[nodiscard]] std::optional<scene::DemStepLimit> scene_step_limit(const scene::Scene& scene);

// e.set_dt(dt) for a Δt that comes from a scene: a refusal becomes a scene::SceneError at the
// key soil.dem.dt (located by the app), with the limit, its formula and the automatic step.
void set_scene_dt(Engine& e, double dt);

} // namespace demfem::dem
