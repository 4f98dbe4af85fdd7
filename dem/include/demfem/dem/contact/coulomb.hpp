// The static/dynamic Coulomb limit of the shear springs (linear_shear.hpp, mindlin.hpp).
#pragma once

#include <cmath>
#include <cstdint>

#include "demfem/dem/contact/contact.hpp"

namespace demfem::dem::contact::detail {

// Shear spring with static/dynamic Coulomb limit (paper eqs. 2.9, 2.12, 2.13).
// ft_trial is the spring force after the elastic increment; returns the admissible force and
// adds the energy taken out of the spring to e_fric.
inline double coulomb(double ft_trial, double fn, double mu_s, double mu_d, double k_t,
                      std::uint8_t& flags, double& e_fric) {
  if (!(fn > 0.0)) { // eq. 2.12: no shear without compression; the spring energy is lost
    e_fric += 0.5 * ft_trial * ft_trial / k_t;
    flags = static_cast<std::uint8_t>(flags & ~kHistSliding);
    return 0.0;
  }
  const bool sliding = (flags & kHistSliding) != 0;
  const double limit = (sliding ? mu_d : mu_s) * fn; // eq. 2.13 with μ_s sticking, μ_D sliding
  if (std::abs(ft_trial) > limit) {
    const double ft = std::copysign(mu_d * fn, ft_trial);
    // Sliding on: slider force × plastic slip increment. Sticking → sliding: the spring energy
    // above the dynamic level is released at once (the force drops from μ_s f_n to μ_D f_n).
    e_fric += sliding ? std::abs(ft * (ft_trial - ft)) / k_t
                      : 0.5 * (ft_trial * ft_trial - ft * ft) / k_t;
    flags = static_cast<std::uint8_t>(flags | kHistSliding);
    return ft;
  }
  flags = static_cast<std::uint8_t>(flags & ~kHistSliding); // slip stopped or reversed: stuck
  return ft_trial;
}

// Resets a pair whose contact ended; the remaining shear spring energy counts as dissipated.
inline void end_contact(ContactHistory& h, double k_t, ContactResult& r) {
  r.e_friction += 0.5 * h.ft * h.ft / k_t;
  h = ContactHistory{};
  r.touching = false;
}

} // namespace demfem::dem::contact::detail
