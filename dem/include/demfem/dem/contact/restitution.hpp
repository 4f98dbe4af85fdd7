// Damping sub-model `restitution`: normal and shear dashpots of one damping ratio ζ, chosen so
// that a head-on collision rebounds at the coefficient of restitution e:
//   ζ = −ln e/√(π² + ln² e), c_n = 2ζ√(m* K_n), c_t = 2ζ√(m* K_s)
// (e.g. Schwager & Pöschel, Computational Granular Dynamics, 2005). No tension: the normal force
// is clamped at 0; the shear dashpot acts while the contact sticks. Needs the linear spring
// (linear_spring.hpp) and the linear shear spring (linear_shear.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "demfem/dem/contact/contact.hpp"
#include "demfem/scene/params.hpp"

namespace demfem::dem::contact {

struct Restitution {
  struct Params {
    static constexpr const char* kName = "restitution";
    double restitution = 0.5; // e
    void fields(scene::ParamVisitor& v) {
      v.number({"restitution", "restitution e", "",
                "linear-restitution: the coefficient of restitution of a head-on collision "
                "(rebound speed / approach speed); sets the dashpots' damping ratio"},
               restitution, scene::in_range(0.0, 1.0));
    }
    void check(scene::ParamCheck& c) const {
      if (!(restitution > 0.0))
        c.error("restitution", "linear-restitution needs restitution in (0, 1]");
    }
  };
  double zeta = 0.0; // the damping ratio ζ(e)

  static double damping_ratio(double e) { // ζ(e) for the linear spring–dashpot
    const double le = std::log(e);
    return -le / std::sqrt(M_PI * M_PI + le * le);
  }

  static constexpr bool kDashpot = true;
  static std::vector<scene::ParamBlock> blocks() { return {scene::ParamBlock(Params{})}; }
  static Restitution from(const scene::ModelChoice& c) {
    return {damping_ratio(c.get<Params>().restitution)};
  }

  void on_first_touch(const ContactInput&, ContactResult&, double&) const {}
  template <class N>
  [[nodiscard]] double normal(double en, const ContactInput& in, const N& n) const {
    const double cn = 2.0 * zeta * std::sqrt(in.m_eff * n.p.kn); // critical-damping fraction ζ
    return std::max(0.0, en + cn * in.vn);
  }
  template <class T>
  [[nodiscard]] double shear(const ContactInput& in, std::uint8_t flags, const T& t) const {
    const double ct = 2.0 * zeta * std::sqrt(in.m_eff * t.p.ks);
    return (flags & kHistSliding) ? 0.0 : -ct * in.vs;
  }
  // ξ = ζ(e); e ≥ 1: none; e = 0 (ζ not finite): critically damped
  [[nodiscard]] double step_xi(double /*kn*/, double /*ks*/, double /*m_star*/) const {
    return std::isfinite(zeta) ? std::max(zeta, 0.0) : 1.0;
  }
};

} // namespace demfem::dem::contact
