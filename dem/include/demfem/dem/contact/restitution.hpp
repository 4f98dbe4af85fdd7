// Damping sub-model `restitution`: normal and shear dashpots of one damping ratio ζ, chosen so
// that a head-on collision rebounds at the coefficient of restitution e:
//   c_n = 2ζ√(m* K_n), c_t = 2ζ√(m* K_s), f_n = max(0, K_n δ + c_n v_n)
// The normal force is clamped at 0 (no tension), so the contact ends when f_n returns to 0, at
// δ > 0, not when δ does: the familiar ζ = −ln e/√(π² + ln² e) (the dashpot whose force may turn
// negative) then rebounds too fast (e = 0.5 gives 0.550). For the clamped law (Schwager &
// Pöschel, "Coefficient of restitution and linear–dashpot model revisited", Granular Matter 9
// (2007) 465, who give the same result): with ω0² = K_n/m*, β = ζ ω0, the overlap of a head-on
// collision from δ(0) = 0, δ'(0) = v is δ(t) = (v/ω) e^{−βt} sin ωt, ω² = ω0² − β²; the force
// m*(ω0² δ + 2β δ') vanishes where tan ωt = −2βω/(ω² − β²), and there δ' = −v e^{−βt}, so
//   e(ζ) = exp(−ζ/√(1 − ζ²) · atan2(2ζ√(1 − ζ²), 2ζ² − 1))   ζ < 1
//   e(1) = e^{−2}
//   e(ζ) = exp(−2ζ arcosh(ζ)/√(ζ² − 1))                        ζ > 1 (δ with sinh, cosh)
// (own derivation; e → 1 − πζ as ζ → 0, e → 1/(4ζ²) as ζ → ∞). e(ζ) decreases monotonically,
// and ζ(e) is its inverse, found once at set-up by bisection to round-off.
// The integrator (symplectic Euler, the dashpot seeing the velocity of the last drift) rebounds
// faster than the continuous law by a first-order term in ω0Δt (measured on its own two-body map:
// +1.8 % at e = 0.1 and 64 steps per contact, +2.2 % at e = 0.5 and 29). The law removes it with
// ζ_Δt = ζ + s ω0Δt, s = (ζ_Δt − ζ)/(ω0Δt) found once at set-up by bisection of that map at
// ω0Δt = 0.02 (discrete_rebound below), so that c_n = 2ζ√(m* K_n) + 2s K_n Δt: the rebound of a
// head-on collision is then within 0.3 % of e at the automatic step (test
// DemContact.LinearRestitutionReboundsAtTheRequestedCoefficient). The shear dashpot has the same
// damping, c_t = 2ζ√(m* K_s) + 2s K_s Δt, and acts while the contact sticks. Needs the linear
// spring (linear_spring.hpp) and the linear shear spring (linear_shear.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "demfem/dem/contact/contact.hpp"
#include "demfem/dem/contact/linear_spring.hpp"
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
  double zeta = 0.0;  // the damping ratio ζ(e)
  double slope = 0.0; // s: the integrator's ζ_Δt = ζ + s ω0Δt

  // e(ζ) of the clamped law, the closed form above.
  static double restitution_of(double zeta) {
    if (!(zeta > 0.0)) return 1.0;
    if (zeta < 1.0) {
      const double s = std::sqrt(1.0 - zeta * zeta);
      return std::exp(-zeta / s * std::atan2(2.0 * zeta * s, 2.0 * zeta * zeta - 1.0));
    }
    if (zeta == 1.0) return std::exp(-2.0);
    return std::exp(-2.0 * zeta * std::acosh(zeta) / std::sqrt(zeta * zeta - 1.0));
  }
  // The inverse of a decreasing function g on [0, ∞) at y < g(0), by bisection to round-off.
  template <class G> static double invert(G g, double y) {
    double lo = 0.0, hi = 1.0;
    while (g(hi) > y && hi < 1e6) hi *= 2.0; // e(ζ) → 1/(4ζ²): a bracket in a few doublings
    for (int k = 0; k < 200 && hi - lo > 1e-15 * hi; ++k) {
      const double mid = 0.5 * (lo + hi);
      (g(mid) > y ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  }
  // ζ(e) (e ≥ 1: 0; e ≤ 0: +∞, critically damped and beyond).
  static double damping_ratio(double e) {
    if (e >= 1.0) return 0.0;
    if (!(e > 0.0)) return std::numeric_limits<double>::infinity();
    return invert(&restitution_of, e);
  }
  // The engine's head-on collision of a pair m* = K_n = 1 at Δt = a (ω0Δt = a) with dashpot
  // ratio z: the touch in the middle of a step, the spring and the dashpot as in evaluate (the
  // closed fraction at the touch, the clamp), symplectic Euler; the rebound speed over the
  // approach speed.
  static double discrete_rebound(double z, double a) {
    double v = 1.0, x = -0.5 * a; // approach speed, overlap
    bool touched = false;
    for (long n = 0; n < 100'000'000; ++n) {
      double f = 0.0;
      if (x > 0.0) {
        touched = true;
        const ContactInput in{x, v, 0.0, 1.0, 1.0, 0.0, 0.0, a, 0.0};
        f = std::max(0.0, detail::linear_spring_force(x, v, a, 1.0, 1.0) +
                              2.0 * z * v * closed_fraction(in));
      }
      v -= f * a;
      x += v * a;
      if (touched && x < 0.0) return -v;
    }
    return 0.0;
  }
  static Restitution with_restitution(double e) {
    Restitution r;
    r.zeta = damping_ratio(e);
    if (std::isfinite(r.zeta) && r.zeta > 0.0) {
      constexpr double a = 0.02;
      r.slope = (invert([](double z) { return discrete_rebound(z, a); }, e) - r.zeta) / a;
    }
    return r;
  }

  static constexpr bool kDashpot = true;
  static std::vector<scene::ParamBlock> blocks() { return {scene::ParamBlock(Params{})}; }
  static Restitution from(const scene::ModelChoice& c) {
    return with_restitution(c.get<Params>().restitution);
  }

  void on_first_touch(const ContactInput&, ContactResult&, double&) const {}
  // The fraction of the last drift v_n Δt that the contact has been closed: 1, or δ/(v_n Δt) in
  // the step of the touch. The dashpot's impulse over a contact, Σ c v_n Δt = c Σ(δ_n − δ_{n−1}),
  // then telescopes from δ = 0 at the touch, not from the overlap δ_{n−1} < 0 one step before it,
  // which would add up to c v Δt (12 % of the approach momentum at e = 0.1 and the automatic step).
  [[nodiscard]] static double closed_fraction(const ContactInput& in) {
    const double d_prev = in.delta - in.vn * in.dt; // the overlap one step ago
    return d_prev < 0.0 && in.vn > 0.0 ? in.delta / (in.vn * in.dt) : 1.0;
  }
  template <class N>
  [[nodiscard]] double normal(double en, const ContactInput& in, const N& n) const {
    const double cn = 2.0 * zeta * std::sqrt(in.m_eff * n.p.kn) + 2.0 * slope * n.p.kn * in.dt;
    return std::max(0.0, en + cn * in.vn * closed_fraction(in));
  }
  template <class T>
  [[nodiscard]] double shear(const ContactInput& in, std::uint8_t flags, const T& t) const {
    const double ct = 2.0 * zeta * std::sqrt(in.m_eff * t.p.ks) + 2.0 * slope * t.p.ks * in.dt;
    return (flags & kHistSliding) ? 0.0 : -ct * in.vs * closed_fraction(in);
  }
  // ξ = ζ(e); e ≥ 1: none; e = 0 (ζ not finite): critically damped
  [[nodiscard]] double step_xi(double /*kn*/, double /*ks*/, double /*m_star*/) const {
    return std::isfinite(zeta) ? std::max(zeta, 0.0) : 1.0;
  }
};

} // namespace demfem::dem::contact
