// Contact law `hertz-mindlin`: the Hertz normal force (hertz.hpp) with the Mindlin–Deresiewicz
// (no-slip) tangential stiffness (mindlin.hpp), the 3D sphere law used by most 2D DEM codes;
// static/dynamic Coulomb limit; no damping.
#pragma once

#include "demfem/dem/contact/hertz.hpp"
#include "demfem/dem/contact/law.hpp"
#include "demfem/dem/contact/mindlin.hpp"

namespace demfem::dem::contact {

struct HertzMindlin : Law<Hertz, NoDamping, Mindlin> {
  static constexpr const char* name = "hertz-mindlin";
  static constexpr const char* summary =
      "Hertz normal force from E, ν with Mindlin's tangential stiffness, Coulomb friction "
      "μ_s/μ_D, no damping";
};

} // namespace demfem::dem::contact
