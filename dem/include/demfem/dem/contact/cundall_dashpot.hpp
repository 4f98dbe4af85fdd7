// Contact law `cundall-dashpot`: Cundall & Strack (1979) linear springs with normal and shear
// dashpots, f_n = max(0, K_n δ + η_n v_n) (eqs. 2.6–2.8), f_t = e_s + d_s with d_s = −η_s v_s,
// d_s = 0 while sliding (eqs. 2.9–2.14).
#pragma once

#include "demfem/dem/contact/dashpot.hpp"
#include "demfem/dem/contact/law.hpp"
#include "demfem/dem/contact/linear_shear.hpp"
#include "demfem/dem/contact/linear_spring.hpp"

namespace demfem::dem::contact {

struct CundallDashpot : Law<LinearSpring, Dashpot, LinearShear> {
  static constexpr const char* name = "cundall-dashpot";
  static constexpr const char* summary =
      "Cundall & Strack (1979): linear springs K_n, K_s with normal and shear dashpots η_n, η_s, "
      "Coulomb friction μ_s/μ_D";
};

} // namespace demfem::dem::contact
