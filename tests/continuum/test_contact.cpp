// Zero-thickness Coulomb contact of the soil with rigid planes (fem::ContactPlane, explicit
// integrator; issue 9 "boundary friction"): an elastic block on a frictional base slides with the
// closed-form relative acceleration a − μ_d g above μ_s g and does not slide below it, it can lift
// off (unilateral), and a frictionless side wall reproduces the roller it replaces.
#include <gtest/gtest.h>

#include "helpers.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "fem.hpp"

using namespace demfem::continuum;
using namespace demfem::continuum::fem;
using demfem::scene::TimeFunction;
using demfem::test::fitted_acceleration;

namespace {
constexpr double kG = 9.81;

// An elastic soil (E, ν 0.3, ρ 2000 kg/m³) under gravity, explicit, direct solver for the K0 state.
Problem elastic_explicit(double young) {
  Problem pb;
  pb.soil = demfem::test::elastic_soil(young, 0.3);
  pb.density = 2000.0;
  pb.gravity = kG;
  pb.linear_solver = "direct";
  pb.integrator = "explicit";
  return pb;
}

// An elastic block 2 m × 0.25 m (ρ = 2000 kg/m³, M = 1000 kg/m; flat, so that rocking barely
// changes the base pressure) resting on a Coulomb base plane z = 0 with μ_s = 0.5, μ_d = 0.2; its
// sides and top are free. Gravity from the K0 state with K0 = 0 (the exact geostatic state of a
// block with free sides).
Problem block(int component, const TimeFunction& accel) {
  Problem pb = elastic_explicit(5.0e7);
  pb.mesh.dx = {0.5, 0.5, 0.5, 0.5};
  pb.mesh.dz = {0.25};
  pb.mesh.refinement = 1;
  pb.left = pb.right = pb.bottom = pb.top = Bc::Free;
  ContactPlane base;
  base.name = "base";
  base.a = {-0.5, 0.0};
  base.b = {2.5, 0.0};
  base.mu_static = 0.5;
  base.mu_dynamic = 0.2;
  pb.contacts.push_back(base);
  pb.shaking_component = component;
  pb.shaking = accel;
  return pb;
}
constexpr double kBlockMass = 2000.0 * 2.0 * 0.25; // [kg/m]

// the mean displacement of 15 points spread over the block
Point mean_displacement(const Model& m) {
  Point s;
  int n = 0;
  for (double x : {0.0, 0.5, 1.0, 1.5, 2.0})
    for (double z : {0.0, 0.125, 0.25}) {
      const Point u = m.displacement({x, z});
      s.x += u.x;
      s.z += u.z;
      ++n;
    }
  return {s.x / n, s.z / n};
}

void advance_to(Model& m, double t_end, double dt = 0.01) {
  while (m.time() < t_end - 1e-9) ASSERT_TRUE(m.dynamic_step(dt).converged) << m.log();
}
} // namespace

// a = 6 m/s² > μ_s g = 4.905 m/s² (ramped up over 0.1 s): the block slides on the base with the
// relative acceleration a − μ_d g = 4.038 m/s² (Coulomb, rigid block): a quadratic fitted to the
// mean displacement over 0.3–0.6 s (every 0.01 s) within 1 %; the frictional work over that
// interval equals μ_d M g × the slip within 1 %; the base carries the weight (mean normal force
// over the interval within 1 % of M g).
TEST(ContinuumContact, BlockSlidesAboveStaticFriction) {
  const double a = 6.0;
  Model m(block(0, TimeFunction::piecewise({{0.0, 0.0}, {0.1, a}, {10.0, a}})));
  ASSERT_TRUE(m.initialise_gravity(true, 0.0, 1).converged) << m.log();
  advance_to(m, 0.3);
  const double u1 = mean_displacement(m).x, w1 = m.contact_force(0).dissipated;
  std::vector<std::pair<double, double>> samples{{m.time(), u1}};
  double normal = 0.0; // time average over every central-difference step
  int sliding = 0, nodes = 0;
  const double h = m.stable_time_step(), t1 = m.time();
  while (m.time() < 0.6 - 1e-9) {
    ASSERT_TRUE(m.dynamic_step(std::min(h, 0.6 - m.time())).converged) << m.log();
    const ContactForce cf = m.contact_force(0);
    normal += -cf.fz * h;
    if (samples.size() < std::size_t((m.time() - t1) / 0.01 + 1.5))
      samples.emplace_back(m.time(), mean_displacement(m).x);
    sliding = cf.sliding;
    nodes = cf.nodes;
  }
  normal /= m.time() - t1;
  const double u2 = mean_displacement(m).x;
  const double rel = fitted_acceleration(samples);
  const double expected = a - 0.2 * kG; // rigid block sliding: a − μ_d g
  const double work = m.contact_force(0).dissipated - w1;
  const double work_expected = 0.2 * kBlockMass * kG * (u2 - u1);
  std::printf("sliding block: relative acceleration %.4f m/s² (a − μ_d g = %.4f, %+.2f %%), slip "
              "%.4f m over 0.3 s, frictional work %.2f J/m (μ_d M g × slip = %.2f, %+.2f %%), "
              "mean normal force %.1f N/m (M g = %.1f), %d of %d nodes sliding\n",
              rel, expected, 100 * (rel - expected) / expected, u2 - u1, work, work_expected,
              100 * (work - work_expected) / work_expected, normal, kBlockMass * kG, sliding,
              nodes);
  EXPECT_NEAR(rel, expected, 0.01 * expected);
  EXPECT_NEAR(work, work_expected, 0.01 * work_expected);
  EXPECT_NEAR(normal, kBlockMass * kG, 0.01 * kBlockMass * kG);
  EXPECT_GT(u2 - u1, 0.3);
}

// a = 3.5 m/s² < μ_s g (but > μ_d g; ramped over 0.2 s): the block sticks. The base's mean slip
// after 0.6 s < 1e-4 m (sliding at μ_d from the ramp's end would give ≈ 0.12 m); the base
// carries the inertial force M a within 2 %.
TEST(ContinuumContact, BlockSticksBelowStaticFriction) {
  const double a = 3.5;
  Model m(block(0, TimeFunction::piecewise({{0.0, 0.0}, {0.2, a}, {10.0, a}})));
  ASSERT_TRUE(m.initialise_gravity(true, 0.0, 1).converged) << m.log();
  advance_to(m, 0.6);
  double slip = 0.0;
  for (double x : {0.0, 0.5, 1.0, 1.5, 2.0}) slip += m.displacement({x, 0.0}).x / 5.0;
  const ContactForce cf = m.contact_force(0);
  std::printf("sticking block: base mean slip %.3e m, %d of %d nodes sliding, tangential force "
              "%.1f N/m (M a = %.1f)\n",
              slip, cf.sliding, cf.nodes, cf.fx, kBlockMass * a);
  EXPECT_LT(std::abs(slip), 1e-4);
  EXPECT_NEAR(cf.fx, kBlockMass * a, 0.02 * kBlockMass * a);
}

// Unilateral: an upward body force of 15 m/s² (> g) for 0.2 s lifts the block off the base: no
// node in contact from 0.05 s on, and the mean rise is ballistic, a − g = 5.19 m/s² fitted over
// 0.05–0.2 s within 1 %; the block then falls back and lands without crossing the plane (every
// base node's uz ≥ −1e-4 m until 1 s; the undamped elastic block keeps bouncing).
TEST(ContinuumContact, BlockLiftsOffAndLandsWithoutPenetration) {
  Model m(block(1, TimeFunction::piecewise({{0.0, 15.0}, {0.2, 15.0}, {0.2001, 0.0}, {10, 0}})));
  ASSERT_TRUE(m.initialise_gravity(true, 0.0, 1).converged) << m.log();
  advance_to(m, 0.05, 0.005);
  std::vector<std::pair<double, double>> samples;
  int touching = 0, open = 0;
  while (m.time() < 0.2 - 1e-9) {
    ASSERT_TRUE(m.dynamic_step(0.005).converged) << m.log();
    samples.emplace_back(m.time(), mean_displacement(m).z);
    touching = std::max(touching, m.contact_force(0).nodes);
    open = m.contact_force(0).open;
  }
  const double rel = fitted_acceleration(samples), expected = 15.0 - kG;
  double lowest = 1e300, highest = 0.0;
  int landed = 0;
  while (m.time() < 1.0 - 1e-9) {
    ASSERT_TRUE(m.dynamic_step(0.005).converged) << m.log();
    for (double x : {0.0, 0.5, 1.0, 1.5, 2.0}) lowest = std::min(lowest, m.displacement({x, 0}).z);
    highest = std::max(highest, mean_displacement(m).z);
    if (m.contact_force(0).nodes > 0) ++landed;
  }
  std::printf("lift-off: ballistic acceleration %.4f m/s² (a − g = %.4f, %+.2f %%), at most %d "
              "nodes in contact while flying, %d open; highest %.4e m (ballistic %.4e), lowest "
              "base uz %.3e m, in contact at %d of 160 samples after the flight\n",
              rel, expected, 100 * (rel - expected) / expected, touching, open, highest,
              0.5 * expected * 0.04 * (1 + expected / kG), lowest, landed);
  EXPECT_NEAR(rel, expected, 0.01 * expected);
  EXPECT_EQ(touching, 0);
  EXPECT_GT(open, 0);
  EXPECT_GT(lowest, -1e-4);
  EXPECT_GT(landed, 0);
}

namespace {
// Elastic soil 4 m × 3 m under a 50 kPa surcharge, fixed base, roller on the right, K0 = 0.5,
// shaken horizontally at 1 m/s², 3.6 Hz; the left side a roller or a frictionless Coulomb plane.
Problem box(bool contact_left) {
  Problem pb = elastic_explicit(2.0e7);
  pb.mesh.dx = {2.0, 2.0};
  pb.mesh.dz = {1.5, 1.5};
  pb.mesh.refinement = 2;
  pb.shaking_component = 0;
  pb.shaking = TimeFunction::sine(1.0, 3.6, 0.0);
  pb.tractions.push_back({{0.0, 3.0}, {4.0, 3.0}, 5.0e4}); // surcharge: no tension at the side
  if (contact_left) {
    ContactPlane left;
    left.name = "left";
    left.a = {0.0, 3.0};
    left.b = {0.0, 0.0};
    left.mu_static = left.mu_dynamic = 0.0;
    pb.contacts.push_back(left);
  }
  return pb;
}
} // namespace

// A frictionless (μ = 0) side plane is today's roller while the soil presses on it (a 50 kPa
// surcharge keeps the side in compression; without it the plane lets the top 0.75 m separate,
// where the roller pulls): over 0.5 s of shaking the displacements at 6 points differ by < 1e-6
// of the largest one.
TEST(ContinuumContact, FrictionlessSidePlaneMatchesRoller) {
  const std::vector<Point> pts = {{0.0, 1.0}, {0.0, 2.5}, {1.0, 1.5},
                                  {2.0, 3.0}, {3.0, 1.0}, {4.0, 2.0}};
  std::vector<Point> u[2];
  double umax = 0.0;
  for (int k = 0; k < 2; ++k) {
    Model m(box(k == 1));
    ASSERT_TRUE(m.initialise_gravity(true, 0.5, 1).converged) << m.log();
    ASSERT_TRUE(m.static_step(1.0).converged) << m.log(); // the surcharge
    while (m.time() < 0.5 - 1e-9) {
      ASSERT_TRUE(m.dynamic_step(0.01).converged) << m.log();
      for (const Point& p : pts) {
        u[k].push_back(m.displacement(p));
        umax = std::max(umax, std::hypot(u[k].back().x, u[k].back().z));
      }
    }
  }
  ASSERT_EQ(u[0].size(), u[1].size());
  double worst = 0.0;
  for (std::size_t i = 0; i < u[0].size(); ++i)
    worst = std::max(worst, std::hypot(u[0][i].x - u[1][i].x, u[0][i].z - u[1][i].z));
  std::printf("frictionless side plane vs roller: max |Δu| = %.3e m of max |u| = %.3e m (%.2e)\n",
              worst, umax, worst / umax);
  EXPECT_GT(umax, 1e-4);
  EXPECT_LT(worst, 1e-6 * umax);
}

// The implicit integrator refuses contact planes.
TEST(ContinuumContact, ImplicitRefusesContactPlanes) {
  Problem pb = block(0, TimeFunction::constant(0.0));
  pb.integrator = "implicit";
  Model m(pb);
  ASSERT_TRUE(m.initialise_gravity(true, 0.0, 1).converged) << m.log();
  EXPECT_THROW(m.dynamic_step(0.01), std::runtime_error);
}

namespace {
// Elastic fill 4 m × 3 m (ρ = 2000 kg/m³) on a fixed base with a roller on the left, against a
// rigid wall 0.2 m thick on the right (every DoF fixed): tied (shared nodes), or not meshed and in
// Coulomb contact through its face x = 4 (Region::contact) with friction μ. K0 = 0.5.
Problem fill_against_wall(bool contact, double mu, double amplitude) {
  Problem pb = elastic_explicit(2.0e7);
  const double W = 4.0, H = 3.0, t = 0.2;
  pb.mesh.dx = {1.0, 1.0, 1.0, 1.0, t};
  pb.mesh.dz = {1.0, 1.0, 1.0};
  pb.mesh.refinement = 2;
  pb.mesh.domain = {{0, 0}, {W, 0}, {W, H}, {0, H}};
  pb.rayleigh_alpha = 1.0;
  Region wall = demfem::test::fixed_rigid_wall(W, t, H, 2.0e10);
  wall.contact = contact;
  pb.regions.push_back(wall);
  if (contact) {
    ContactPlane face;
    face.name = "wall";
    face.a = {W, 0};
    face.b = {W, H};
    face.mu_static = mu;
    face.mu_dynamic = std::min(mu, 0.2);
    face.region = 0;
    pb.contacts.push_back(face);
  }
  if (amplitude > 0) {
    pb.shaking_component = 0;
    pb.shaking = TimeFunction::sine(amplitude, 3.6, 0.0);
  }
  return pb;
}
} // namespace

// A smooth (μ = 0) contact wall in the K0 state: σ_x = K0 σ_z integrates to the thrust
// ½ K0 γ H² (to 1e-6 from the implicit reactions at t = 0, within 0.5 % from the explicit contact
// forces over 0.3 s at rest), and the pressure profile from the nodal contact forces is
// K0 γ (H − z) in every one of 6 bins within 1 %.
TEST(ContinuumContact, SmoothContactWallK0ThrustClosedForm) {
  Model m(fill_against_wall(true, 0.0, 0.0));
  ASSERT_TRUE(m.initialise_gravity(true, 0.5, 1).converged) << m.log();
  const double H = 3.0, gamma = 2000.0 * kG, P = 0.5 * 0.5 * gamma * H * H; // ½K0γH²
  const double P0 = m.soil_reaction(0).fx;
  double worst = 0.0;
  while (m.time() < 0.3 - 1e-9) {
    ASSERT_TRUE(m.dynamic_step(0.01).converged) << m.log();
    worst = std::max(worst, std::abs(m.soil_reaction(0).fx - P) / P);
  }
  Reaction F;
  const auto prof = m.soil_pressure(0, 0.0, H, 6, &F);
  double worst_bin = 0.0;
  for (std::size_t b = 0; b < prof.size(); ++b) {
    const double zm = (double(b) + 0.5) * H / 6, expected = 0.5 * gamma * (H - zm);
    worst_bin = std::max(worst_bin, std::abs(prof[b] - expected) / expected);
  }
  std::printf(
      "smooth contact wall: K0 thrust %.2f N/m (½K0γH² = %.2f, %.1e), explicit at rest "
      "max deviation %.2e, pressure bins worst %.2e, bins sum × h = %.2f, force (%.2f, %.2f)\n",
      P0, P, (P0 - P) / P, worst, worst_bin,
      [&] {
        double s = 0;
        for (double v : prof) s += v * H / 6;
        return s;
      }(),
      F.fx, F.fz);
  EXPECT_NEAR(P0, P, 1e-6 * P);
  EXPECT_LT(worst, 5e-3);
  EXPECT_LT(worst_bin, 1e-2);
}

// A rough (μ_s = 0.5) contact wall against the tied wall it replaces: the same K0 thrust (1e-3),
// and under 0.6 s of 2 m/s² shaking at 3.6 Hz thrust histories of the same size (the peaks
// within 25 %; printed for the record), the contact wall letting the soil slide and separate.
TEST(ContinuumContact, RoughContactWallAgainstTiedWall) {
  double P0[2], peak[2];
  int open = 0;
  for (int k = 0; k < 2; ++k) {
    Model m(fill_against_wall(k == 1, 0.5, 2.0));
    ASSERT_TRUE(m.initialise_gravity(true, 0.5, 1).converged) << m.log();
    P0[k] = m.soil_reaction(0).fx;
    peak[k] = P0[k];
    while (m.time() < 0.6 - 1e-9) {
      ASSERT_TRUE(m.dynamic_step(0.01).converged) << m.log();
      peak[k] = std::max(peak[k], m.soil_reaction(0).fx);
      if (k == 1) open = std::max(open, m.contact_force(0).open);
    }
  }
  std::printf("rough contact wall vs tied: K0 thrust %.2f vs %.2f N/m, peak under shaking %.2f vs "
              "%.2f N/m (%+.2f %%), at most %d wall nodes separated\n",
              P0[1], P0[0], peak[1], peak[0], 100 * (peak[1] - peak[0]) / peak[0], open);
  EXPECT_NEAR(P0[1], P0[0], 1e-3 * P0[0]);
  EXPECT_NEAR(peak[1], peak[0], 0.25 * peak[0]);
}
