// Damping sub-model `dashpot` (Cundall & Strack 1979): normal and shear dashpots,
// d_n = η_n v_n (paper eq. 2.7) added to the spring force and the sum clamped at 0 (no tension,
// eq. 2.8, and no dashpot pull); d_s = −η_s v_s while sticking, 0 while sliding (eqs. 2.10–2.14).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "demfem/dem/contact/contact.hpp"
#include "demfem/scene/params.hpp"

namespace demfem::dem::contact {

struct Dashpot {
  struct Params {
    static constexpr const char* kName = "dashpot";
    double eta_n = 0.0, eta_s = 0.0; // [N·s/m]
    void fields(scene::ParamVisitor& v) {
      v.number({"eta_n", "η_n", "N·s/m",
                "cundall-dashpot: normal dashpot, f_n = max(0, K_n δ + η_n v_n) with v_n the "
                "approach speed (paper eq. 2.7)"},
               eta_n, scene::non_negative());
      v.number({"eta_s", "η_s", "N·s/m",
                "cundall-dashpot: shear dashpot, −η_s v_s added to the shear force while the "
                "contact sticks (paper eq. 2.10)"},
               eta_s, scene::non_negative());
    }
  } p;

  static constexpr bool kDashpot = true;
  static std::vector<scene::ParamBlock> blocks() { return {scene::ParamBlock(Params{})}; }
  static Dashpot from(const scene::ModelChoice& c) { return {c.get<Params>()}; }

  void on_first_touch(const ContactInput&, ContactResult&, double&) const {}
  template <class N>
  [[nodiscard]] double normal(double en, const ContactInput& in, const N& /*normal*/) const {
    const double dn = p.eta_n * in.vn; // eq. 2.7: d_n = η_n Δu_n/Δt
    return std::max(0.0, en + dn);     // no tension (eq. 2.8)
  }
  template <class T>
  [[nodiscard]] double shear(const ContactInput& in, std::uint8_t flags, const T&) const {
    return (flags & kHistSliding) ? 0.0 : -p.eta_s * in.vs; // eq. 2.10, 2.13
  }
  // ξ = η / (2√(m* k)), the critical-damping fraction of each dashpot (the larger one)
  [[nodiscard]] double step_xi(double kn, double ks, double m_star) const {
    double xi = 0.0;
    if (kn > 0.0) xi = std::max(xi, p.eta_n / (2.0 * std::sqrt(m_star * kn)));
    if (ks > 0.0) xi = std::max(xi, p.eta_s / (2.0 * std::sqrt(m_star * ks)));
    return xi;
  }
};

} // namespace demfem::dem::contact
