// Closed forms of DEM verification scenes that the error-vs-time study measures against and the
// comparison report names: two listed disks meeting head-on.
#pragma once

#include <optional>
#include <string>

#include "demfem/scene/scene.hpp"

namespace demfem::dem {

// Two listed disks meeting head-on (cases/verification/head_on_collision.toml): the closed form
// of the collision. Empty, with `why`, for any other scene.
struct HeadOnClosedForm {
  double m_star = 0;       // reduced mass [kg]
  double approach = 0;     // relative normal approach speed [m/s]
  double separation = 0;   // relative speed after the collision [m/s]
  double dissipated = 0;   // ½ m* v² (1 − K²) above V_0, else 0 [J]
  double touch_time = 0;   // first touch [s]
  double contact_time = 0; // π √(m*/K_n) [s]
  double radius_sum = 0;   // r1 + r2 [m]
  double kinetic_cm = 0;   // kinetic energy of the centre of mass [J]
  // centre distance at time t after the pair separated [m]
  [[nodiscard]] double distance(double t) const {
    return radius_sum + separation * (t - touch_time - contact_time);
  }
};
[[nodiscard]] std::optional<HeadOnClosedForm> head_on_closed_form(const scene::Scene& scene,
                                                                  std::string* why = nullptr);

} // namespace demfem::dem
