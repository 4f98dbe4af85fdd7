// Normal sub-model `bonded linear spring`: the linear spring (linear_spring.hpp) that, with
// `tension`, bonds at first touch and carries tension up to tensile_strength (paper, pile case 4);
// beyond it the bond breaks and the pair separates. Without tension: no tension (eq. 2.8). Used by
// cundall-rebound.
#pragma once

#include <algorithm>
#include <vector>

#include "demfem/dem/contact/linear_spring.hpp"

namespace demfem::dem::contact {

struct BondedLinearSpring {
  struct Bond {
    static constexpr const char* kName = "bond";
    bool tension = false;
    double tensile_strength = 0.0; // [N]
    void fields(scene::ParamVisitor& v) {
      v.flag({"tension", "tension", "",
              "cundall-rebound: contacts bond at first touch and carry tension (f_n = K_n δ < 0) "
              "up to tensile_strength; false: no tension (paper eq. 2.8)"},
             tension);
      v.number({"tensile_strength", "tensile strength", "N",
                "cundall-rebound with tension: the tensile force at which a bond breaks (the "
                "pair then separates)"},
               tensile_strength, scene::non_negative());
    }
  };
  LinearSpring spring;
  Bond bond;

  static constexpr const char* kForceFormula = LinearSpring::kForceFormula;
  static std::vector<scene::ParamBlock> blocks() {
    return {scene::ParamBlock(LinearSpring::Params{}), scene::ParamBlock(Bond{})};
  }
  static BondedLinearSpring from(const scene::ModelChoice& c) {
    return {LinearSpring::from(c), c.get<Bond>()};
  }

  // The contact is bonded: it may carry tension.
  [[nodiscard]] bool bonded(const ContactHistory& h) const {
    return bond.tension && (h.flags & kHistBonded);
  }
  // A bonded contact at overlap δ ≤ 0 holds while its tension −K_n δ is within the strength.
  [[nodiscard]] bool holds(double delta) const {
    return -spring.p.kn * delta <= bond.tensile_strength;
  }
  void on_first_touch(ContactHistory& h) const {
    if (bond.tension) h.flags |= kHistBonded;
  }
  // eq. 2.6 (e_n = K_n δ), energy-consistent at touch and release; a bond in tension keeps the
  // plain K_n δ.
  [[nodiscard]] double force(const ContactInput& in, double vn, bool bonded) const {
    return bonded ? spring.p.kn * in.delta : spring.force(in, vn, false);
  }
  [[nodiscard]] double energy(const ContactInput& in, double /*f*/, bool bonded) const {
    const double dp = bonded ? in.delta : std::max(in.delta, 0.0);
    return 0.5 * spring.p.kn * dp * dp; // spring energy at the current overlap
  }
  [[nodiscard]] double step_kn(double r_min) const { return spring.step_kn(r_min); }
  [[nodiscard]] double stiffness(double r_eff, double delta) const {
    return spring.stiffness(r_eff, delta);
  }
  [[nodiscard]] double elastic_force(double delta, double r_eff) const {
    return spring.elastic_force(delta, r_eff);
  }
  [[nodiscard]] double overlap(double f, double r_eff) const { return spring.overlap(f, r_eff); }
};

} // namespace demfem::dem::contact
