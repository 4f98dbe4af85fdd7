// The coefficient of lateral earth pressure at rest, K0 = σ'h/σ'v of a normally consolidated soil
// (the initial stresses of the continuum). Header-only, C++17-compatible.
#pragma once

#include <cmath>

namespace demfem::continuum::constitutive {

// Jaky (1944): K0 = 1 − sin φ' (φ' [rad]).
[[nodiscard]] inline double jaky_k0(double friction_angle) {
  return 1.0 - std::sin(friction_angle);
}

// A stated K0 (≥ 0), else Jaky's from the friction angle [rad] (soil.continuum.k0 < 0: unset).
[[nodiscard]] inline double k0_at_rest(double k0, double friction_angle) {
  return k0 >= 0.0 ? k0 : jaky_k0(friction_angle);
}

} // namespace demfem::continuum::constitutive
