// Contact law `cundall-rebound`, the paper's: a linear normal spring e_n = K_n δ (eq. 2.6
// integrated from first touch, where δ = 0), no tension (eq. 2.8) unless `tension` (a bond,
// bonded_spring.hpp); an incremental shear spring (eq. 2.9) with static friction μ_s while stuck
// and μ_D while sliding (eq. 2.13); no dashpots, but the rebound rule at impacts faster than V_0
// (rebound.hpp). Without tension the engine runs it through a vectorised pair kernel
// (dem/src/pair_kernel.cpp), bit-identical to evaluate().
#pragma once

#include "demfem/dem/contact/bonded_spring.hpp"
#include "demfem/dem/contact/law.hpp"
#include "demfem/dem/contact/linear_shear.hpp"
#include "demfem/dem/contact/rebound.hpp"

namespace demfem::dem::contact {

struct CundallRebound : Law<BondedLinearSpring, Rebound, LinearShear> {
  static constexpr const char* name = "cundall-rebound";
  static constexpr const char* summary =
      "the paper's law: linear springs K_n, K_s, Coulomb friction μ_s/μ_D, Newton restitution K "
      "at impacts faster than V_0 (slower contacts elastic), optional bonds carrying tension";
};

} // namespace demfem::dem::contact
