// Contact law `linear-restitution`: linear springs with normal and shear dashpots of the damping
// ratio that gives a head-on collision the coefficient of restitution e (restitution.hpp), no
// tension, Coulomb friction.
#pragma once

#include "demfem/dem/contact/law.hpp"
#include "demfem/dem/contact/linear_shear.hpp"
#include "demfem/dem/contact/linear_spring.hpp"
#include "demfem/dem/contact/restitution.hpp"

namespace demfem::dem::contact {

struct LinearRestitution : Law<LinearSpring, Restitution, LinearShear> {
  static constexpr const char* name = "linear-restitution";
  static constexpr int kVersion = 2; // 2: ζ of the clamped dashpot (restitution.hpp)
  static constexpr const char* summary =
      "linear springs K_n, K_s with dashpots damped to the coefficient of restitution e of a "
      "head-on collision, Coulomb friction μ_s/μ_D";
};

} // namespace demfem::dem::contact
