// The DEM's stable time step.
//
// ---- Derivation
// ----------------------------------------------------------------------------------- Symplectic
// Euler (paper eqs. 2.16–2.18: v ← v + a Δt, x ← x + v Δt) is the leapfrog scheme; on a linear
// system M ẍ = −K x it is stable iff Δt < 2/ω_max, ω_max² the largest eigenvalue of M⁻¹K (Hairer,
// Lubich & Wanner, Geometric Numerical Integration, 2006, §I.1; Belytschko, Liu & Moran, Nonlinear
// Finite Elements, 2000, eq. 6.3.10). Per disk the degrees of freedom are x, z and θ with masses m,
// m and I; a contact adds a normal spring k_n on the relative normal displacement and a shear
// spring k_s on the relative displacement of the contact points, s = (u_j − u_i)·t − r_i θ_i − r_j
// θ_j (contact/contact.hpp; the engine's arms r − δ/2 are shorter, which only lowers the
// frequencies).
//
// One contact between two particles (the pair, its reduced mass m* = m_i m_j/(m_i + m_j)):
//   normal mode         ω_n² = k_n (1/m_i + 1/m_j)                      (= k_n/m*)
//   shear–rotation mode ω_s² = k_s (1/m_i + 1/m_j + r_i²/I_i + r_j²/I_j)
// (the second from s̈ = −k_s s (1/m_i + 1/m_j + r_i²/I_i + r_j²/I_j), translations and rotations
// of both bodies driven by the one shear force). For two equal disks (I = ½ m r²) ω_n² = 2k_n/m
// and ω_s² = 6k_s/m; for equal spheres (I = (2/5) m r²) ω_s² = 7k_s/m. A particle against a wall
// or a structure (infinite mass) has k_n/m and 3k_s/m: lower than a pair of the smallest
// particles, so the pair of the two smallest particles gives the stiffest contact,
//   ω_pair² = max(2k_n, 2(1 + g) k_s)/m_min,   g = m r²/I (2 disk, 5/2 sphere).
// The former check 2√(m_min/max(k_n, k_s)) was the one-disk-on-a-wall normal mode: √2 too large
// for a pair, and for k_s = k_n 2.45× too large for the shear–rotation mode.
//
// Coordination. A particle with Z contacts is stiffer than an isolated pair. Gershgorin's theorem
// on the mass-normalised stiffness (with (a − b)² ≤ (1/m_i + 1/m_j)(m_i a² + m_j b²) per contact)
// gives the rigorous ω_max² ≤ max_i Σ_{contacts of i} ω_c² ≤ Z_max ω_pair², Z_max = 6 for the
// smallest disk among equal or larger ones: conservative by 1.5–2 in ω². The exact value for
// the densest packing of equal disks, the triangular lattice (coordination 6), computed here
// from its eigenvalues (periodic 12 × 12 patch, k_s/k_n = 0 … 1, own computation, 2026):
//   ω_max² = max(6k_n + 4k_s, 12 k_s r²/I)/m
// — the first the translational zone-boundary mode (6k_n/m with k_s = 0), the second all disks
// turning together (every contact's shear spring stretched by 2rθ, 6 contacts). Measured in the
// same computation: square lattice 4k_n/m…16k_s/m, a column of 20 disks on a floor ≤ 3.98 k_n/m.
// Both parts are below C ω_pair² with
//   C = max(4, 6g/(1 + g))   (4 for disks, 30/7 ≈ 4.29 for spheres),
// tight for the rotation mode when k_s ≥ k_n/2 (disks). So the step bound is
//   Δt_crit = 2/ω_max,  ω_max² = C ω_pair²;   for disks Δt_crit = √(m_min/max(2k_n, 6k_s)).
// This is the exact limit of the densest equal-disk packing, not a rigorous bound for every
// conceivable network (Gershgorin's Z_max = 6 would be): large initial overlaps (more than 6
// neighbours) or structures much lighter than the particles can exceed it, and the run's
// overlap and energy-closure watch (run/energy_watch.cpp) stops them.
//
// Damping. A dashpot of damping ratio ξ lowers the limit of the explicit scheme to
// Δt_crit = (2/ω_max)(√(1 + ξ²) − ξ) (Belytschko, Liu & Moran 2000, eq. 6.3.36). Contact
// dashpots: ξ = η/(2√(m* k)) with m* = m_min/2 (cundall-dashpot η_n, η_s), or the restitution's
// ζ = −ln e/√(π² + ln² e) (linear-restitution); global damping (eqs. 2.1, 2.2: C, D per unit
// mass/inertia): ξ = max(C, D)/(2ω_max). The largest ξ is used.
//
// Rolling resistance. A rolling spring k_r [N·m/rad] on the relative rotation θ_i − θ_j of a pair
// (contact/contact.hpp) adds the mode ω_r² = k_r (1/I_i + 1/I_j) = 2k_r/I_min for two of the
// smallest particles; with Z_max = 6 contacts turning a particle against its neighbours, its
// share of ω_max² is at most 6ω_r² (Gershgorin, as above), added to the translational and
// shear–rotation bound: ω_max² = C ω_pair² + 6ω_r². Without rolling resistance (k_r = 0) the bound
// is the one above.
//
// Hertz–Mindlin: the tangent stiffnesses at 5 % overlap of r_min, R* = r_min/2 (as
// contact/hertz.hpp, contact/mindlin.hpp): k_n = 2E*√(R*δ), k_s = 8G*√(R*δ) (Johnson, Contact
// Mechanics, 1985, §4.2; Mindlin 1949), E* = E/(2(1 − ν²)), G* = E/(4(2 − ν)(1 + ν)).
#include "demfem/dem/stable_step.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <variant>

#include <fmt/format.h>

#include "demfem/dem/engine.hpp"
#include "demfem/scene/load.hpp"

namespace demfem::dem {

namespace {
// Contacts of one particle that a rolling mode loads at once (Gershgorin, Z_max = 6, above).
constexpr double kRollingMargin = 6.0;
} // namespace

double coordination_margin(double inertia_factor) {
  const double g = 1.0 / inertia_factor; // m r²/I
  return std::max(4.0, 6.0 * g / (1.0 + g));
}

StepBound critical_step(const StepParams& p) {
  StepBound b;
  b.dt = std::numeric_limits<double>::infinity();
  if (!(p.m_min > 0.0) || !(p.r_min > 0.0)) return b;
  const double kn = p.kn, ks = p.ks;
  b.kn = kn;
  b.ks = ks;
  const double g = 1.0 / p.inertia_factor;
  const double wn2 = 2.0 * kn / p.m_min;             // pair normal mode, k_n/m*
  const double ws2 = 2.0 * (1.0 + g) * ks / p.m_min; // pair shear–rotation mode
  const double wp2 = std::max(wn2, ws2);
  if (!(wp2 > 0.0)) return b;
  b.shear_mode = ws2 > wn2;
  b.omega_pair = std::sqrt(wp2);
  double wmax2 = coordination_margin(p.inertia_factor) * wp2;
  if (p.kr > 0.0) { // a rolling spring's mode, added (see above)
    b.omega_rolling = std::sqrt(2.0 * p.kr / (p.inertia_factor * p.m_min * p.r_min * p.r_min));
    wmax2 += kRollingMargin * b.omega_rolling * b.omega_rolling;
  }
  b.omega_max = std::sqrt(wmax2);
  // Damping ratios (see the derivation above): the contact's (from the law) and global damping's.
  double xi = p.xi;
  xi = std::max(xi, std::max(p.damping_c, p.damping_d) / (2.0 * b.omega_max));
  b.damping_factor = std::sqrt(1.0 + xi * xi) - xi;
  b.dt = 2.0 / b.omega_max * b.damping_factor;
  return b;
}

std::string StepBound::formula() const {
  if (omega_rolling > 0.0)
    return fmt::format(
        "2/ω_max{}, ω_max² = C·ω_pair² + 6ω_r², ω_pair = {:.4g} rad/s ({} mode of a pair of the "
        "smallest particles: max(2k_n, 2(1 + mr²/I)k_s)/m_min with k_n = {:.4g}, k_s = {:.4g} "
        "N/m), C = {:.3g} for coordination, ω_r = {:.4g} rad/s (rolling spring: 2k_r/I_min)",
        damping_factor < 1.0 ? fmt::format("·{:.4f} (damping)", damping_factor) : "", omega_pair,
        shear_mode ? "shear–rotation" : "normal", kn, ks,
        omega_pair > 0.0 ? (omega_max * omega_max - 6.0 * omega_rolling * omega_rolling) /
                               (omega_pair * omega_pair)
                         : 0.0,
        omega_rolling);
  return fmt::format("2/ω_max{}, ω_max² = C·ω_pair², ω_pair = {:.4g} rad/s ({} mode of a pair of "
                     "the smallest particles: max(2k_n, 2(1 + mr²/I)k_s)/m_min with k_n = {:.4g}, "
                     "k_s = {:.4g} N/m), C = {:.3g} for coordination",
                     damping_factor < 1.0 ? fmt::format("·{:.4f} (damping)", damping_factor) : "",
                     omega_pair, shear_mode ? "shear–rotation" : "normal", kn, ks,
                     omega_pair > 0.0 ? omega_max * omega_max / (omega_pair * omega_pair) : 0.0);
}

StepParams step_params(const EngineConfig& c, double m_min, double r_min) {
  StepParams p;
  const auto k =
      std::visit([&](const auto& law) { return law.step_stiffness(r_min, 0.5 * m_min); }, c.law);
  p.kn = k.kn;
  p.ks = k.ks;
  p.xi = k.xi;
  p.kr = k.kr;
  p.damping_c = c.damping_c;
  p.damping_d = c.damping_d;
  p.m_min = m_min;
  p.r_min = r_min;
  p.inertia_factor = c.sphere_mass ? 0.4 : 0.5; // as Engine::compute_mass
  return p;
}

double scene_min_radius(const scene::DemSoil& d) {
  double r = std::numeric_limits<double>::infinity();
  if (!d.particles.empty()) {
    for (const auto& q : d.particles) r = std::min(r, q[2]);
  } else {
    switch (d.radius.kind) {
    case scene::RadiusDistribution::Kind::Uniform:
    case scene::RadiusDistribution::Kind::Equal:
      r = d.radius.min;
      break;
    case scene::RadiusDistribution::Kind::Table:
      for (const auto& [rr, w] : d.radius.table)
        if (w > 0.0) r = std::min(r, rr);
      break;
    }
  }
  return std::isfinite(r) && r > 0.0 ? r : 0.0;
}

std::optional<StepBound> scene_critical_step(const scene::Scene& scene) {
  if (!scene.soil.dem) return std::nullopt;
  const auto& d = *scene.soil.dem;
  const double r = scene_min_radius(d);
  if (!(r > 0.0)) return std::nullopt;
  // The engine's masses (Engine::compute_mass): disk ρπr²t (PFC2D) or sphere ρ(4/3)πr³.
  const double m = d.sphere_mass ? d.density * 4.0 / 3.0 * std::numbers::pi * r * r * r
                                 : d.density * std::numbers::pi * r * r * d.thickness;
  EngineConfig c = make_config(scene);
  return critical_step(step_params(c, m, r));
}

std::optional<scene::DemStepLimit> scene_step_limit(const scene::Scene& scene) {
  const auto b = scene_critical_step(scene);
  if (!b) return std::nullopt;
  return scene::DemStepLimit{b->dt, b->formula()};
}

void set_scene_dt(Engine& e, double dt) {
  try {
    e.set_dt(dt);
  } catch (const StepRefused& r) {
    scene::Diagnostic d;
    d.key = "soil.dem.dt";
    d.message = scene::dem_step_refusal(r.dt, {r.limit, r.formula}, r.auto_dt);
    throw scene::SceneError({d});
  }
}

} // namespace demfem::dem
