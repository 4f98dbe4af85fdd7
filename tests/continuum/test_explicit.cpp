// Explicit central-difference integrator (continuum.integrator = "explicit"): stable step, energy
// conservation, shear-column resonance against V_s/(4H) and the implicit integrator, the K0
// handover at rest, and explicit against implicit on a short shaken retaining-wall problem.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include "fem.hpp"
#include "helpers.hpp"

using namespace demfem::continuum;
using namespace demfem::continuum::fem;

namespace {
constexpr double kPi = 3.14159265358979323846;

std::vector<double> uniform(double length, int n) {
  return std::vector<double>(static_cast<std::size_t>(n), length / n);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Elastic shear column (periodic sides, horizontal motion only, fixed base), as in
// ContinuumDynamic.ShearColumnFirstFrequency.
Problem shear_column(const char* integrator) {
  Problem pb;
  pb.mesh.dx = {1.0};
  pb.mesh.dz = std::vector<double>(10, 1.0);
  pb.mesh.refinement = 1;
  pb.mesh.periodic_x = true;
  pb.fix_z_everywhere = true;
  pb.soil = demfem::test::elastic_soil(3.0e7, 0.3);
  pb.density = 1700.0;
  pb.gravity = 0.0;
  pb.integrator = integrator;
  return pb;
}

// Frequency of the top's free vibration from its downward zero crossings.
double top_frequency(Model& m, double H, double dt, int steps) {
  std::vector<double> crossings;
  double prev = m.displacement({0.5, H}).x, t_prev = m.time();
  for (int k = 1; k <= steps; ++k) {
    const StepStats st = m.dynamic_step(dt);
    EXPECT_TRUE(st.converged) << m.log();
    const double cur = m.displacement({0.5, H}).x;
    if (prev > 0 && cur <= 0) crossings.push_back(t_prev + dt * prev / (prev - cur));
    prev = cur;
    t_prev = m.time();
  }
  if (crossings.size() < 3) return 0.0;
  return double(crossings.size() - 1) / (crossings.back() - crossings.front());
}
} // namespace

// The automatic step is safety × 2/ω_max with ω_max from the element bound (Irons 1970). For
// Q2 elements ω_max h/c_p is O(10); the bound must lie above the 1D estimate 2c_p/h of a Q1 bar
// (a lower bound on the highest frequency of any finer discretisation) and the step must be
// stable: 2000 steps of an undamped column stay bounded.
TEST(ContinuumExplicit, StableStepFromElementBound) {
  Problem pb = shear_column("explicit");
  Model m(pb);
  const double dt = m.stable_time_step();
  const double E = pb.soil.elasticity().hooke.young, nu = pb.soil.elasticity().hooke.poisson;
  const double cp = std::sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / pb.density);
  const double h = 0.5;         // cells of 1 m refined once
  const double dt_bar = h / cp; // 2/ω with ω = 2c_p/h (Q1 bar, lumped)
  std::printf("explicit stable step: %.4e s (h/c_p = %.4e s, ratio %.3f)\n", dt, h / cp,
              dt / (h / cp));
  EXPECT_GT(dt, 0.05 * dt_bar);
  EXPECT_LT(dt, 0.8 * dt_bar);
  m.set_displacement([&](Point p) { return Point{0.01 * std::sin(kPi * p.z / 20.0), 0.0}; });
  const StepStats st = m.dynamic_step(2000 * dt);
  EXPECT_TRUE(st.converged);
  EXPECT_EQ(st.substeps, 2000);
  EXPECT_LT(std::abs(m.displacement({0.5, 10.0}).x), 0.011);
}

// Undamped linear elasticity: the central-difference method conserves energy up to an O((ω dt)²)
// oscillation without drift (Belytschko, Liu & Moran 2000 §6.2.3). Kinetic (lumped mass) plus
// strain energy of the first shear mode, 10⁴ steps: relative change < 1e-3.
TEST(ContinuumExplicit, UndampedElasticEnergyConserved) {
  Problem pb = shear_column("explicit");
  pb.fix_z_everywhere = false; // both components free (P and S waves)
  Model m(pb);
  m.set_displacement([&](Point p) {
    return Point{0.01 * std::sin(kPi * p.z / 20.0), 0.002 * std::sin(kPi * p.z / 20.0)};
  });
  const double e0 = m.elastic_energy();
  const double dt = m.stable_time_step();
  double worst = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < 100; ++k) {
    ASSERT_TRUE(m.dynamic_step(100 * dt).converged) << m.log();
    worst = std::max(worst, std::abs(m.elastic_energy() - e0) / e0);
  }
  std::printf("explicit energy: %d dofs, 10^4 steps of %.3e s (%.3f s), max |ΔE|/E0 = %.2e, "
              "wall %.2f s\n",
              int(m.n_dofs()), dt, m.time(), worst, seconds_since(t0));
  EXPECT_LT(worst, 1e-3);
}

// First shear-beam frequency f1 = V_s/(4H) (e.g. Kramer 1996 §7.2): explicit within 2 % of the
// closed form and within 0.5 % of the implicit (Newmark) result on the same mesh.
TEST(ContinuumExplicit, ShearColumnResonanceMatchesClosedFormAndImplicit) {
  const double H = 10.0;
  double f[2] = {0, 0};
  const char* names[2] = {"explicit", "implicit"};
  Problem pb0 = shear_column("explicit");
  const double G = pb0.soil.elasticity().hooke.shear_modulus();
  const double f_exact = std::sqrt(G / pb0.density) / (4 * H); // V_s/(4H)
  const double T = 1.0 / f_exact;
  for (int k = 0; k < 2; ++k) {
    Model m(shear_column(names[k]));
    m.set_displacement([&](Point p) { return Point{0.01 * std::sin(kPi * p.z / (2 * H)), 0.0}; });
    const auto t0 = std::chrono::steady_clock::now();
    f[k] = top_frequency(m, H, T / 200, 700);
    std::printf("shear column %s: f = %.5f Hz (V_s/4H = %.5f), rel. err %.2e, wall %.2f s\n",
                names[k], f[k], f_exact, (f[k] - f_exact) / f_exact, seconds_since(t0));
  }
  EXPECT_NEAR(f[0], f_exact, 0.02 * f_exact);
  EXPECT_NEAR(f[0], f[1], 0.005 * f[1]);
}

namespace {
// The retaining-wall problem of cases/retaining_wall.toml at a coarse mesh: 8 m × 5.6 m of
// Mohr–Coulomb backfill (φ = 30°, ψ = 0, c = 0) against a fixed rigid wall on the right, K0
// initial state, base shaking.
Problem wall_problem(const char* integrator, double amplitude, int refinement) {
  Problem pb;
  const double W = 8.0, H = 5.6, t = 0.2;
  pb.mesh.dx = uniform(W, 6);
  pb.mesh.dx.push_back(t);
  pb.mesh.dz = uniform(H, 4);
  pb.mesh.refinement = refinement;
  pb.mesh.domain = {{0, 0}, {W, 0}, {W, H}, {0, H}};
  pb.soil = demfem::test::mohr_coulomb_soil(3.0e7, 0.3, 30.0 * kPi / 180.0, 0.0);
  pb.density = 2170.0;
  pb.gravity = 9.81;
  pb.linear_solver = "direct";
  pb.newton_tolerance = 1e-6;
  pb.integrator = integrator;
  Region wall = demfem::test::fixed_rigid_wall(W, t, H, 3.0e10);
  pb.regions.push_back(wall);
  if (amplitude > 0) {
    pb.shaking_component = 0;
    pb.shaking = demfem::scene::TimeFunction::sine(amplitude, 3.6, 0.0);
  }
  return pb;
}
} // namespace

// Handover from the implicit K0 state to explicit dynamics: at rest (no shaking) the thrust on
// the wall does not jump at t = 0 (first step within 1e-4 of the static value) and stays within
// 0.5 % over 0.5 s with light mass-proportional damping; the soil stays at rest (|u| < 1e-6 m).
TEST(ContinuumExplicit, K0HandoverNoJumpAtRest) {
  Problem pb = wall_problem("explicit", 0.0, 1);
  pb.rayleigh_alpha = 1.0;
  Model m(pb);
  ASSERT_TRUE(m.initialise_gravity(true, 0.5, 1).converged) << m.log();
  const double P0 = m.soil_reaction(0).fx;
  const double dt = m.stable_time_step();
  ASSERT_TRUE(m.dynamic_step(dt).converged);
  const double P1 = m.soil_reaction(0).fx;
  double worst = 0.0;
  while (m.time() < 0.5) {
    ASSERT_TRUE(m.dynamic_step(0.01).converged) << m.log();
    worst = std::max(worst, std::abs(m.soil_reaction(0).fx - P0) / P0);
  }
  const Point u = m.displacement({4.0, 5.6});
  std::printf("K0 handover: static thrust %.1f N/m, after one explicit step %.1f (rel. %.1e), "
              "max deviation over 0.5 s %.2e, surface u = (%.2e, %.2e) m\n",
              P0, P1, (P1 - P0) / P0, worst, u.x, u.z);
  EXPECT_NEAR(P1, P0, 1e-4 * P0);
  EXPECT_LT(worst, 5e-3);
  EXPECT_LT(std::hypot(u.x, u.z), 1e-6);
}

// Explicit against implicit (Newmark, dt = 0.005 s) on the shaken wall: 2 m/s² at 3.6 Hz for
// 0.6 s at refinement 1. Thrust histories sampled every 0.01 s agree within 5 % of the at-rest
// thrust (RMS of the difference) and their peaks within 5 %.
TEST(ContinuumExplicit, ShakenWallExplicitMatchesImplicit) {
  std::vector<double> thrust[2];
  const char* names[2] = {"explicit", "implicit"};
  double P0 = 0.0;
  for (int k = 0; k < 2; ++k) {
    Problem pb = wall_problem(names[k], 2.0, 1);
    Model m(pb);
    ASSERT_TRUE(m.initialise_gravity(true, 0.5, 1).converged) << m.log();
    P0 = m.soil_reaction(0).fx;
    const auto t0 = std::chrono::steady_clock::now();
    while (m.time() < 0.6 - 1e-9) {
      const double h = k == 0 ? 0.01 : 0.005;
      ASSERT_TRUE(m.dynamic_step(h).converged) << m.log();
      if (k == 1) {
        ASSERT_TRUE(m.dynamic_step(h).converged) << m.log();
      }
      thrust[k].push_back(m.soil_reaction(0).fx);
    }
    std::printf("shaken wall %s: %zu dofs, wall %.2f s, peak thrust %.1f N/m (at rest %.1f)\n",
                names[k], m.n_dofs(), seconds_since(t0),
                *std::max_element(thrust[k].begin(), thrust[k].end()), P0);
  }
  ASSERT_EQ(thrust[0].size(), thrust[1].size());
  double rms = 0;
  for (std::size_t i = 0; i < thrust[0].size(); ++i)
    rms += (thrust[0][i] - thrust[1][i]) * (thrust[0][i] - thrust[1][i]);
  rms = std::sqrt(rms / double(thrust[0].size()));
  const double pe = *std::max_element(thrust[0].begin(), thrust[0].end());
  const double pi = *std::max_element(thrust[1].begin(), thrust[1].end());
  std::printf("shaken wall: RMS(explicit − implicit) = %.1f N/m = %.2f %% of the at-rest thrust; "
              "peaks %.1f vs %.1f (%.2f %%)\n",
              rms, 100 * rms / P0, pe, pi, 100 * (pe - pi) / pi);
  EXPECT_LT(rms, 0.05 * P0);
  EXPECT_NEAR(pe, pi, 0.05 * pi);
}

// Slow loading (issue 10, verification): a rigid rough strip footing pushed slowly into weightless
// undrained clay (φ = 0, cohesion c) with the explicit integrator reaches the Prandtl pressure
// (2 + π)c (Prandtl 1920) within 5 %, as the implicit, displacement-controlled
// ContinuumStatic.StripFootingUndrainedBearingCapacity does on the same mesh. Half model (x ≥ 0,
// roller at the symmetry line); the footing, B/2 wide, is a rigid region on the surface with its
// vertical motion prescribed: 0.03 B in T = 2 s (≈ 40 shear-wave transits of the 5 B deep box),
// starting and ending at rest (u = −s(t/T − sin(2πt/T)/2π)), FLAC-style local damping 0.8.
// Measured: q/c = 5.2305 (+1.7 %), 6,118 dofs, ≈ 22 s of CPU.
TEST(ContinuumExplicit, SlowlyLoadedFootingReachesPrandtl) {
  const double B = 1.0, c = 1.0e4, s = 0.03 * B, T = 2.0, tf = 0.25 * B;
  Problem pb = demfem::test::undrained_half_space(B, c, 1.3);
  pb.integrator = "explicit";
  pb.degree = 2;
  pb.mesh.dz.push_back(tf); // the footing's layer above the surface
  pb.mesh.refinement = 0;
  pb.mesh.domain = {{0, -5.0 * B}, {5.0 * B, -5.0 * B}, {5.0 * B, 0}, {0, 0}};
  pb.local_damping = 0.8;
  Region f;
  f.name = "footing";
  f.outline = {{0, 0}, {0.5 * B, 0}, {0.5 * B, tf}, {0, tf}};
  f.material.young = 1e12;
  f.material.poisson = 0.2;
  f.rigid = true;
  f.dead_weight = false;
  f.pivot = {0, 0};
  f.load_point = f.pivot;
  f.mode[0] = f.mode[2] = Region::Mode::Fixed;
  f.mode[1] = Region::Mode::Prescribed;
  f.motion[1] = demfem::scene::TimeFunction::sum(
      {demfem::scene::TimeFunction::ramp(-s / T),
       demfem::scene::TimeFunction::sine(s / (2.0 * M_PI), 1.0 / T)});
  pb.regions.push_back(f);
  Model m(pb);
  const auto t0 = std::chrono::steady_clock::now();
  int steps = 0;
  while (m.time() < T - 1e-12) {
    ASSERT_TRUE(m.dynamic_step(std::min(0.05, T - m.time())).converged) << m.log();
    ++steps;
    if (steps % 10 == 0)
      std::printf("  t=%.2f s settlement/B=%.4f q/c=%.4f\n", m.time(), -m.region_motion(0).uz / B,
                  m.soil_reaction(0).fz / (0.5 * B) / c);
  }
  const double q = m.soil_reaction(0).fz / (0.5 * B); // the soil pushes the footing up
  const double exact = (2.0 + M_PI) * c;
  std::printf("explicit footing: dofs=%zu settlement/B=%.4f q/c=%.4f (exact %.4f) rel.err=%.3e "
              "wall=%.1fs\n",
              m.n_dofs(), -m.region_motion(0).uz / B, q / c, exact / c, (q - exact) / exact,
              seconds_since(t0));
  EXPECT_NEAR(q, exact, 0.05 * exact);
}
