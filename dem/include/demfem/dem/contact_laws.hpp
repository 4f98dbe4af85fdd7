// Contact laws of the DEM engine: small evaluator structs, each in one place with its parameter
// block, its stable-step data (step_stiffness) and its evaluate() member. The engine builds one
// AnyContactLaw from its configuration (make_contact_law, engine.hpp) and visits it once per
// step; the contact loop is a template instantiated once per law, so there is no virtual call or
// switch per contact. A new law is one more struct here, one more alternative of AnyContactLaw
// and one more case in make_contact_law. No I/O, no allocation.
//
// ---- Sign convention (the one used everywhere in dem/) ------------------------------------------
// Coordinates x right, z up. Rotations and moments counter-clockwise positive.
// For a contact between i and j (j may be a boundary):
//   n = (x_i − x_j)/|x_i − x_j|   unit normal pointing from j to i (for a boundary: from the
//                                 closest boundary point to the centre of i)
//   t = (−n_z, n_x)               n rotated counter-clockwise by 90°
//   δ = r_i + r_j − |x_i − x_j|   overlap, > 0 when touching (paper eq. 2.3)
//   contact point: the middle of the overlap, at arm l_i = r_i − δ/2 from i and l_j = r_j − δ/2
//   from j (boundary: on the boundary surface, l_i = r_i − δ). With this choice the pair
//   torques balance the moment of the pair forces exactly, so angular momentum is conserved.
//   Relative velocity of i's contact point w.r.t. j's:  v_rel = v_i − v_j − (l_i ω_i + l_j ω_j) t
//   v_n = −v_rel·n   normal approach speed (approach positive, paper eq. 2.5)
//   v_s =  v_rel·t   slip speed
// The law returns f_n (compression positive) and f_t; the force on i is F = f_n n + f_t t,
// on j it is −F; the moments are M_i = −l_i f_t and M_j = −l_j f_t (paper eq. 2.15 up to
// the arm). Shear springs are updated as f_t ← f_t − k_s v_s Δt, i.e. they oppose slip; the
// power f_t v_s of the shear force equals minus the rate of the spring energy f_t²/(2 k_s).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <variant>

namespace demfem::dem {

enum ContactHistoryFlag : std::uint8_t {
  kHistActive = 1u << 0,  // the pair has touched (history exists)
  kHistSliding = 1u << 1, // Coulomb limit reached: dynamic friction applies
  kHistBonded = 1u << 2,  // tension option: the contact may carry tension
};

// Persistent per-pair state, kept across neighbour rebuilds.
struct ContactHistory {
  double ft = 0.0;        // shear spring force e_s [N]
  float fn = 0.0f;        // last normal force (output, energy) [N]
  std::uint8_t flags = 0; // ContactHistoryFlag
};

// Geometry and kinematics of one contact in one step.
struct ContactInput {
  double delta; // overlap [m]
  double vn;    // approach speed [m/s]
  double vs;    // slip speed [m/s]
  double m_eff; // m_i m_j/(m_i + m_j), or m_i against a boundary [kg]
  double r_eff; // r_i r_j/(r_i + r_j), or r_i against a boundary [m]
  double mu_s;  // static friction
  double mu_d;  // dynamic friction
  double dt;    // [s]
};

struct ContactResult {
  double fn = 0.0; // normal force incl. dashpot, compression positive [N]
  double ft = 0.0; // shear force [N]
  // Rebound at first touch (cundall-rebound): the contact's approach speed v_n and the approach
  // its impulse leaves, K v_n. The engine applies the impulses after the pair loop, contact by
  // contact (Engine::apply_rebounds), so that contacts of one particle that first touch in the
  // same step share one collision; it books the energy. rebound_vn = 0: no rebound.
  double rebound_vn = 0.0, rebound_to = 0.0; // [m/s]
  double e_friction = 0.0;                   // energy dissipated by friction in this step [J]
  double e_damping = 0.0;                    // energy dissipated by dashpots in this step [J]
  double e_normal = 0.0;                     // normal spring energy after the step [J]
  double e_shear = 0.0;                      // shear spring energy after the step [J]
  bool touching = false;                     // false: the history was reset (contact ended)
};

namespace detail {

// ---- Normal spring at contact onset and release (the three linear-spring laws) ----------------
// The spring force is geometric, f_n = K_n δ: eq. 2.6 (e_n ← e_n + K_n Δu_n) accumulated from
// the true first touch, where δ = 0, equals K_n δ, so the incremental form's error of starting
// with a full step's Δu_n is absent by construction (this engine never had it). What remains is
// the time discretisation of the switch itself. Symplectic Euler is leapfrog with staggered
// velocities; over a contact its kinetic-energy change is −Σ_n f_n (δ_{n+1} − δ_{n−1})/2, which
// for f_n = K_n δ_n telescopes to (K_n/2)(δ_N δ_{N+1} − δ_0 δ_1): the steps either side of the
// touch (δ_0 < 0 < δ_1) and of the release (δ_N > 0 > δ_{N+1}) leave ½ K_n δ₀δ₁-sized errors of
// random sign whose mean is not zero. Measured: a dilute elastic gas at the default Δt gains
// energy × 6.8 and blows up within 1e5 steps (test DemConservation.DiluteElasticGasEnergyDrift…),
// a frictional settle's budget misses by 5 %. Fix (own derivation, this file): choose f_n so
// that every step does the telescoping work exactly,
//   f_n (δ_{n+1} − δ_{n−1}) = K_n δ_n⁺ (δ_{n+1}⁺ − δ_{n−1}⁺),   δ⁺ = max(δ, 0),
// with δ_{n−1} = δ_n − v_n Δt (the pair's last drift) and δ_{n+1} = δ_n + (v_n − f_n Δt/m*) Δt.
// While the contact stays closed this is exactly f_n = K_n δ_n (the paper's eq. 2.6); in the
// step after the touch and the step before the release it is the root of a quadratic. The sum
// over a contact then telescopes to zero: an isolated elastic impact returns its kinetic energy
// to round-off at any Δt (1D check at ω Δt = 0.2–0.9: |ΔE/E| < 1e-15). Other forces acting in
// the same step (gravity, other contacts) are not in the prediction; their effect is O(Δt²).
// Hertz–Mindlin (f ∝ δ^{3/2}, zero stiffness at touch) keeps f(δ).
inline double linear_spring_force(double delta, double vn, double dt, double kn, double m_eff) {
  if (!(delta > 0.0)) return 0.0;
  const double f_closed = kn * delta;    // eq. 2.6
  const double A = dt * dt / m_eff;      // δ_{n+1} decrease per unit force
  const double d_prev = delta - vn * dt; // overlap one step ago
  const double d_next = delta + vn * dt - f_closed * A;
  if (d_prev >= 0.0 && d_next >= 0.0) return f_closed;
  if (d_prev <
      0.0) { // touch inside the last step (vn > 0): f (2 v_n Δt − f A) = K δ (δ + v_n Δt − f A)
    const double b = 2.0 * vn * dt + kn * delta * A, c = kn * delta * (delta + vn * dt);
    const double disc = b * b - 4.0 * A * c;
    if (disc >= 0.0 && b > 0.0) {
      const double f = 2.0 * c / (b + std::sqrt(disc)); // smaller root, stable form
      if (delta + vn * dt - f * A >= 0.0) return f;
    }
    return 0.0; // touch and release inside one step: no work is the exact answer
  }
  // Release inside the next step (vn < 0): f (2 v_n Δt − f A) = −K δ δ_{n−1}, positive root.
  const double s = std::sqrt(vn * vn * dt * dt + A * kn * delta * d_prev);
  const double f = kn * delta * d_prev / (s - vn * dt);
  if (s - vn * dt > 0.0 && delta + vn * dt - f * A < 0.0) return f;
  return f_closed;
}

// linear_spring_force's first case, d_prev ≥ 0 and d_next ≥ 0, as the vectorised pair kernel
// tests it (dem/src/pair_kernel.cpp), for f_n = K_n δ > 0 and finite masses m_i, m_j: without the
// two divisions of m* and A, d_next ≥ 0 is (δ + v_n Δt) m_i m_j ≥ f_n Δt² (m_i + m_j), taken with
// a relative margin of 1e-12, far above the few roundings by which the two forms differ. True
// only where linear_spring_force's own arithmetic has d_next ≥ 0 too (test
// DemPairKernel.StaysClosedTestImpliesTheLaws); a contact inside the margin is left to the
// scalar law. Branch-free, so that it vectorises. dt2 = Δt·Δt.
[[gnu::always_inline]] inline bool stays_closed(double delta, double vn, double dt, double dt2,
                                                double fc, double mi, double mj) {
  constexpr double kMargin = 1.0 + 1e-12;
  const double d_prev = delta - vn * dt;
  const double lhs = (delta + vn * dt) * (mi * mj);
  const double rhs = fc * dt2 * (mi + mj);
  // rhs inside [1e-290, 1e300]: no underflow or overflow spoils the relative margin
  return (d_prev >= 0.0) & (lhs >= rhs * kMargin) & (rhs >= 1e-290) & (rhs <= 1e300);
}

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

} // namespace detail

// What the stable time step needs from a law (stable_step.cpp): the stiffnesses of one contact
// between two of the smallest particles (radius r_min, pair mass m* = m_min/2) and the damping
// ratio ξ of that contact's dashpots.
struct StepStiffness {
  double kn = 0.0, ks = 0.0, xi = 0.0;
};

// ---- cundall-rebound: the paper's law ----------------------------------------------------------
// Linear normal spring e_n = K_n δ (eq. 2.6 integrated from first touch, where δ = 0), no tension
// (eq. 2.8) unless `tension` (then the contact bonds at first touch and carries tension up to
// tensile_strength; beyond it the bond breaks and the pair separates); incremental shear spring
// (eq. 2.9) with static friction μ_s while stuck and μ_D while sliding (eq. 2.13), no dashpots.
// Rebound (paper §2.1.2 iv, read as Newton restitution, see paper.md §1): a contact whose
// normal approach speed at first touch exceeds V_0 receives, in that step, a normal impulse
// P = m*(1 − K) v_n along the line of centres, equal and opposite on the two bodies. The
// approach speed drops to K v_n, the elastic spring then returns it unchanged, so the pair
// separates at K times its approach speed. Momentum and angular momentum are conserved (the
// impulse acts along the line of centres); absolute velocities are never rescaled. The energy
// ½ m* v_n² (1 − K²) is booked as rebound dissipation. Slower contacts stay elastic.
// Contacts of a particle that first touch in the same step (a disk landing on two disks, or on
// two walls at once) are one collision: the engine applies their impulses one after the other,
// each seeing the approach the earlier ones left, P = m* max(0, w − K v_n) with w the current
// approach (sequential impulses, Engine::apply_rebounds), so no contact's approach is driven
// below K times its own and the loss is booked once. The law reports v_n and K v_n only.
// Friction cap (a modelling choice): the Coulomb limit μ f_n (eq. 2.13) sees the spring
// force f_n only, not the rebound impulse P/Δt, so the impulse carries no tangential part. The
// spring then sees the reduced approach speed K v_n, and the friction acting over the contact is
// that of the gentle elastic rebound: a disk hitting a floor at 2 m/s normal and 1 m/s tangential
// (μ = 0.5, K = 0.1) keeps 0.80 of its tangential speed (test DemStability.FrictionCapSees…),
// where Newton restitution with Coulomb friction on the impulse (|P_t| ≤ μ P_n) would keep at
// most 2/3 (it reaches the disk's rolling limit v_t' = (2/3) v_t). Oblique impacts above V_0 thus
// lose less tangential momentum than in impulse-based codes.
struct CundallRebound {
  struct Params {
    double kn = 1.0e6, ks = 3.0e5; // [N/m]
    double rebound = 0.1;          // K
    double v0 = 1.0;               // V_0 [m/s]
    bool tension = false;
    double tensile_strength = 0.0; // [N]
  } p;

  static constexpr const char* name = "cundall-rebound";
  // The rebound impulse acts once per collision, not as a dashpot: ξ = 0.
  [[nodiscard]] StepStiffness step_stiffness(double /*r_min*/, double /*m_star*/) const {
    return {p.kn, p.ks, 0.0};
  }

  ContactResult evaluate(const ContactInput& in, ContactHistory& h) const {
    ContactResult r;
    const bool bonded = p.tension && (h.flags & kHistBonded);
    if (in.delta <= 0.0) {
      if (!(bonded && -p.kn * in.delta <= p.tensile_strength)) {
        if (h.flags != 0) detail::end_contact(h, p.ks, r); // eq. 2.8: no tension
        return r;
      }
    }
    double vn_spring = in.vn;
    if (!(h.flags & kHistActive)) { // first touch
      h.flags = kHistActive;
      if (p.tension) h.flags |= kHistBonded;
      if (in.vn > p.v0) { // Newton restitution, see above (the engine applies the impulse)
        r.rebound_vn = in.vn;
        r.rebound_to = p.rebound * in.vn;
        vn_spring = r.rebound_to; // the spring sees the approach after the impulse
      }
    }
    // eq. 2.6 (e_n = K_n δ), energy-consistent at touch and release (see above); a bond in
    // tension keeps the plain K_n δ.
    const double fn = bonded
                          ? p.kn * in.delta
                          : detail::linear_spring_force(in.delta, vn_spring, in.dt, p.kn, in.m_eff);
    const double ft_trial = h.ft - p.ks * in.vs * in.dt; // eq. 2.9 (e_s ← e_s + K_s Δu_s)
    h.ft = detail::coulomb(ft_trial, fn, in.mu_s, in.mu_d, p.ks, h.flags, r.e_friction);
    h.fn = static_cast<float>(fn);
    r.fn = fn;
    r.ft = h.ft;
    const double dp = bonded ? in.delta : std::max(in.delta, 0.0);
    r.e_normal = 0.5 * p.kn * dp * dp; // spring energy at the current overlap
    r.e_shear = 0.5 * h.ft * h.ft / p.ks;
    r.touching = true;
    return r;
  }
};

// ---- cundall-dashpot: Cundall & Strack (1979) springs with normal and shear dashpots -----------
// f_n = K_n δ + η_n v_n (eqs. 2.6, 2.7), clamped at 0 (no tension, eq. 2.8, and no dashpot
// pull); f_t = e_s + d_s with d_s = −η_s v_s, d_s = 0 while sliding (eqs. 2.9–2.14).
struct CundallDashpot {
  struct Params {
    double kn = 1.0e6, ks = 3.0e5, eta_n = 0.0, eta_s = 0.0;
  } p;

  static constexpr const char* name = "cundall-dashpot";
  // ξ = η / (2√(m* k)), the critical-damping fraction of each dashpot (the larger one)
  [[nodiscard]] StepStiffness step_stiffness(double /*r_min*/, double m_star) const {
    double xi = 0.0;
    if (p.kn > 0.0) xi = std::max(xi, p.eta_n / (2.0 * std::sqrt(m_star * p.kn)));
    if (p.ks > 0.0) xi = std::max(xi, p.eta_s / (2.0 * std::sqrt(m_star * p.ks)));
    return {p.kn, p.ks, xi};
  }

  ContactResult evaluate(const ContactInput& in, ContactHistory& h) const {
    ContactResult r;
    if (in.delta <= 0.0) {
      if (h.flags != 0) detail::end_contact(h, p.ks, r);
      return r;
    }
    h.flags |= kHistActive;
    const double en =
        detail::linear_spring_force(in.delta, in.vn, in.dt, p.kn, in.m_eff); // eq. 2.6
    const double dn = p.eta_n * in.vn;                   // eq. 2.7: d_n = η_n Δu_n/Δt
    const double fn = std::max(0.0, en + dn);            // no tension (eq. 2.8)
    const double ft_trial = h.ft - p.ks * in.vs * in.dt; // eq. 2.9
    h.ft = detail::coulomb(ft_trial, en, in.mu_s, in.mu_d, p.ks, h.flags, r.e_friction);
    const double ds = (h.flags & kHistSliding) ? 0.0 : -p.eta_s * in.vs; // eq. 2.10, 2.13
    r.fn = fn;
    r.ft = h.ft + ds;
    r.e_damping = ((fn - en) * in.vn - ds * in.vs) * in.dt; // power of the dashpots
    h.fn = static_cast<float>(fn);
    r.e_normal = 0.5 * p.kn * std::max(in.delta, 0.0) * std::max(in.delta, 0.0);
    r.e_shear = 0.5 * h.ft * h.ft / p.ks;
    r.touching = true;
    return r;
  }
};

// ---- linear-restitution: spring–dashpot with the damping ratio of a restitution coefficient ----
// ζ = −ln e/√(π² + ln² e), c_n = 2ζ√(m* K_n) (e.g. Schwager & Pöschel, Computational Granular
// Dynamics, 2005), same ζ on the shear spring: c_t = 2ζ√(m* K_s). No tension.
struct LinearRestitution {
  struct Params {
    double kn = 1.0e6, ks = 3.0e5, zeta = 0.0;
  } p;

  static double damping_ratio(double e) { // ζ(e) for the linear spring–dashpot
    const double le = std::log(e);
    return -le / std::sqrt(M_PI * M_PI + le * le);
  }
  static constexpr const char* name = "linear-restitution";
  // ξ = ζ(e); e ≥ 1: none; e = 0 (ζ not finite): critically damped
  [[nodiscard]] StepStiffness step_stiffness(double /*r_min*/, double /*m_star*/) const {
    return {p.kn, p.ks, std::isfinite(p.zeta) ? std::max(p.zeta, 0.0) : 1.0};
  }

  ContactResult evaluate(const ContactInput& in, ContactHistory& h) const {
    ContactResult r;
    if (in.delta <= 0.0) {
      if (h.flags != 0) detail::end_contact(h, p.ks, r);
      return r;
    }
    h.flags |= kHistActive;
    const double en =
        detail::linear_spring_force(in.delta, in.vn, in.dt, p.kn, in.m_eff); // eq. 2.6
    const double cn = 2.0 * p.zeta * std::sqrt(in.m_eff * p.kn); // critical-damping fraction ζ
    const double fn = std::max(0.0, en + cn * in.vn);
    const double ft_trial = h.ft - p.ks * in.vs * in.dt;
    h.ft = detail::coulomb(ft_trial, en, in.mu_s, in.mu_d, p.ks, h.flags, r.e_friction);
    const double ct = 2.0 * p.zeta * std::sqrt(in.m_eff * p.ks);
    const double ds = (h.flags & kHistSliding) ? 0.0 : -ct * in.vs;
    r.fn = fn;
    r.ft = h.ft + ds;
    r.e_damping = ((fn - en) * in.vn - ds * in.vs) * in.dt;
    h.fn = static_cast<float>(fn);
    r.e_normal = 0.5 * p.kn * std::max(in.delta, 0.0) * std::max(in.delta, 0.0);
    r.e_shear = 0.5 * h.ft * h.ft / p.ks;
    r.touching = true;
    return r;
  }
};

// ---- hertz-mindlin: Hertz normal force with Mindlin–Deresiewicz (no-slip) tangential stiffness
// The 3D sphere law used by most 2D DEM codes (its force is in N whatever the thickness):
//   f_n = (4/3) E* √(R*) δ^{3/2},  E* = E/(2(1 − ν²))          (Johnson, Contact Mechanics, 4.22)
//   k_t = 8 G* √(R* δ),            G* = E/(4(2 − ν)(1 + ν))     (Mindlin 1949, equal materials)
// Incremental shear spring with the current k_t; static/dynamic Coulomb limit; no damping.
struct HertzMindlin {
  struct Params {
    double e_star = 1.0, g_star = 1.0;
  } p;

  static constexpr const char* name = "hertz-mindlin";
  // Tangent stiffnesses at δ = 5 % of the smallest radius, R* = r_min/2: k_n = dF/dδ =
  // 2E*√(R*δ) (Johnson, Contact Mechanics, eq. 4.22), k_s = 8G*√(R*δ) (Mindlin 1949)
  [[nodiscard]] StepStiffness step_stiffness(double r_min, double /*m_star*/) const {
    const double root = std::sqrt(0.5 * r_min * 0.05 * r_min);
    return {2.0 * p.e_star * root, 8.0 * p.g_star * root, 0.0};
  }

  ContactResult evaluate(const ContactInput& in, ContactHistory& h) const {
    ContactResult r;
    const double kt = 8.0 * p.g_star * std::sqrt(in.r_eff * std::max(in.delta, 0.0));
    if (in.delta <= 0.0) {
      h = ContactHistory{}; // k_t → 0 as δ → 0: the shear spring is already unloaded
      return r;
    }
    h.flags |= kHistActive;
    const double sq = std::sqrt(in.r_eff * in.delta);
    const double fn = 4.0 / 3.0 * p.e_star * sq * in.delta; // Hertz
    const double ft_trial = h.ft - kt * in.vs * in.dt;
    h.ft = detail::coulomb(ft_trial, fn, in.mu_s, in.mu_d, kt, h.flags, r.e_friction);
    r.fn = fn;
    r.ft = h.ft;
    h.fn = static_cast<float>(fn);
    r.e_normal = 0.4 * fn * in.delta; // ∫ f_n dδ = (2/5) f_n δ
    r.e_shear = 0.5 * h.ft * h.ft / kt;
    r.touching = true;
    return r;
  }
};

// The laws the engine knows; one is chosen per engine (make_contact_law) and visited per step.
using AnyContactLaw = std::variant<CundallRebound, CundallDashpot, LinearRestitution, HertzMindlin>;

} // namespace demfem::dem
