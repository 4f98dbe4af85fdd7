// Continuum rows of `demfem study stability`: stiff and extreme cases of the
// plane-strain solver, each on a small problem with a closed form or a bound, so that a row says
// whether the solver completes within its bound or stops with its specific diagnostic. Shared by
// the study (app) and tests/continuum.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "demfem/scene/scene.hpp"

namespace demfem::continuum {

struct StabilityCase {
  std::string name, description;
  std::string outcome; // "completed", "refused" (at setup, with the cause) or "stopped" (cause)
  std::string cause;   // refusal or stop diagnostic
  std::string measure; // what was measured, with the numbers, in words
  double value = 0.0;  // the measured quantity (see measure)
  double bound = 0.0;  // its closed form or bound
  int newton_iterations = 0;
  int load_steps = 0;
  std::vector<double> residuals; // final Newton residual of each load step
  std::size_t dofs = 0;
  double wall_seconds = 0.0;
};

// Rigid smooth strip footing (B = 2 m) rocking on an elastic half-plane at Poisson ratio `nu`,
// with or without B-bar: K_r = M/θ against πGB²/(8(1 − ν)) (Gazetas 1991). Without B-bar the
// near-incompressible soil locks: K_r rises above the closed form.
[[nodiscard]] StabilityCase rocking_locking_case(double nu, bool bbar, int degree);

// The same footing on an elastic block E_block = ratio × E_soil (0.25 m thick, tied to the soil):
// the direct solver must carry the stiffness contrast (K_r equal to that of the same block 10³×
// stiffer, already rigid in effect: the bound) and the explicit stable step shrinks with √ratio
// (reported).
[[nodiscard]] StabilityCase stiff_structure_case(double ratio, int degree);

// Uniform pressure q = factor × (2 + π)c on a strip (half-width 0.5 m) over weightless undrained
// Mohr–Coulomb clay (φ = 0), load-controlled in equal static steps: below the Prandtl (1920)
// limit the run completes; beyond it Newton finds no equilibrium and the run stops at the load
// factor it reached (step cuts exhausted).
[[nodiscard]] StabilityCase bearing_capacity_case(double factor, int degree);

// The scene's own continuum (its mesh, structures and seating; apply a calibration first) at
// Poisson ratio `nu`, with or without B-bar, run through its static stage (K0 state and the
// seating of its structures: Newton on the scene's mesh) and a few explicit steps at the stable
// step of that ν. Measures each seated structure's settlement (locking: smaller without B-bar;
// no closed form, the B-bar row is the reference) and the stable step's shrinkage against the
// scene's own ν (the P-wave speed grows as ν → 0.5).
[[nodiscard]] StabilityCase scene_locking_case(const scene::Scene& scene, double nu, bool bbar);

// The scene's continuum with the explicit integrator at continuum.dt = factor × its stable step
// (the scene's moduli: apply a calibration first): above 1 it must be refused before any
// computation, at continuum.dt, with the stable step and how it was obtained.
[[nodiscard]] StabilityCase explicit_step_case(const scene::Scene& scene, double factor);

} // namespace demfem::continuum
