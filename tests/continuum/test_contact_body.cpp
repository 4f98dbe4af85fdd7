// Coulomb contact between the soil and a MOVING rigid structure (Region::contact with a DoF not
// fixed; explicit integrator; issue 9 "boundary friction"): the body is not meshed, its faces are
// contact planes that move with it, and the contact forces are solved with its equation of motion
// (Explicit::contact_body). Closed forms: the weight carried at rest, Coulomb
// sticking/sliding of a pushed block, lift-off of a footing under a moment (which the tied footing
// cannot do), exact momentum of body + soil through an impact, and the pure-rotation DoF mode.
#include <gtest/gtest.h>

#include "helpers.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "fem.hpp"

using namespace demfem::continuum;
using namespace demfem::continuum::fem;
using demfem::scene::TimeFunction;
using demfem::test::fitted_acceleration;

namespace {
constexpr double kG = 9.81;
// soil layer 6 m × 1.5 m (elastic, E = 20 MPa, ν = 0.3, ρ = 2000 kg/m³; rollers on the sides,
// fixed base), a rigid block 2 m × 0.5 m (ρ = 2000 kg/m³) resting on its surface at x = 2…4
constexpr double kB = 2.0, kH = 0.5, kTop = 1.5, kX0 = 2.0, kX1 = 4.0;
constexpr double kMass = 2000.0 * kB * kH; // [kg/m]
constexpr double kWeight = kMass * kG;     // [N/m]
constexpr double kMuS = 0.5, kMuD = 0.2;   // the block's face

// contact: the block is unmeshed and in Coulomb contact through its base; otherwise tied
Problem layer_with_block(bool contact, bool gravity = true) {
  Problem pb;
  pb.soil = demfem::test::elastic_soil(2.0e7, 0.3);
  pb.density = 2000.0;
  pb.gravity = gravity ? kG : 0.0;
  pb.linear_solver = "direct";
  pb.integrator = "explicit";
  pb.mesh.dx = {1, 1, 1, 1, 1, 1};
  pb.mesh.dz = {0.5, 0.5, 0.5, kH};
  pb.mesh.refinement = 1;
  pb.mesh.domain = {{0, 0}, {6, 0}, {6, kTop}, {0, kTop}};
  Region r;
  r.name = "block";
  r.outline = {{kX0, kTop}, {kX1, kTop}, {kX1, kTop + kH}, {kX0, kTop + kH}};
  r.material.young = 2.0e10;
  r.material.poisson = 0.2;
  r.density = 2000.0;
  r.rigid = true;
  r.pivot = r.load_point = {0.5 * (kX0 + kX1), kTop}; // base centre
  r.contact = contact;
  pb.regions.push_back(r);
  if (contact) {
    ContactPlane base;
    base.name = "block";
    base.a = {kX0, kTop};
    base.b = {kX1, kTop};
    base.mu_static = kMuS;
    base.mu_dynamic = kMuD;
    base.region = 0;
    pb.contacts.push_back(base);
  }
  return pb;
}

void advance_to(Model& m, double t_end, double dt = 0.01) {
  while (m.time() < t_end - 1e-9) ASSERT_TRUE(m.dynamic_step(dt).converged) << m.log();
}

// Penetration of the soil surface into the block's base at x (soil uz − block uz; > 0 crosses).
double penetration(const Model& m, double x) {
  const auto q = m.region_motion(0);
  const double xp = 0.5 * (kX0 + kX1);
  return m.displacement({x, kTop}).z - (q.uz + q.rotation * (x - xp));
}

} // namespace

// A free block (all three DoFs free) released on the layer at t = 0 (its weight acts from then,
// as in the scenes) settles under FLAC local damping 0.7: after 2 s the contact force on it is its
// weight within 1e-3 (vertical) and 1e-3 W (horizontal), and at no sampled time (every 0.01 s) does
// the soil surface cross its base by more than 1e-6 of the settlement.
TEST(ContinuumContactBody, FreeBlockComesToRestOnItsWeight) {
  Problem pb = layer_with_block(true);
  pb.local_damping = 0.7;
  Model m(pb);
  ASSERT_TRUE(m.initialise_gravity(true, 0.3 / 0.7, 1).converged) << m.log();
  double worst = 0.0;
  while (m.time() < 2.0 - 1e-9) {
    ASSERT_TRUE(m.dynamic_step(0.01).converged) << m.log();
    for (double x : {kX0, 2.5, 3.0, 3.5, kX1}) worst = std::max(worst, penetration(m, x));
  }
  const Reaction r = m.soil_reaction(0);
  const auto q = m.region_motion(0);
  const ContactForce cf = m.contact_force(0);
  std::printf("block at rest: soil force (%.3f, %.3f) N/m (W = %.3f, %+.2e), settlement %.4e m, "
              "rotation %.2e rad, worst penetration %.2e m, %d nodes in contact, %d open\n%s",
              r.fx, r.fz, kWeight, (r.fz - kWeight) / kWeight, -q.uz, q.rotation, worst, cf.nodes,
              cf.open, m.contact_body_summary().c_str());
  EXPECT_NEAR(r.fz, kWeight, 1e-3 * kWeight);
  EXPECT_LT(std::abs(r.fx), 1e-3 * kWeight);
  EXPECT_GT(-q.uz, 1e-4); // it did settle
  EXPECT_LT(worst, 1e-6 * -q.uz);
}

namespace {
// The block settled (0–0.3 s) and then pushed at its base centre by F (ramped over 0.05 s): the
// block's displacement samples every 0.01 s over 0.45–0.75 s, and the contact state at 0.75 s.
struct Push {
  std::vector<std::pair<double, double>> ux;
  ContactForce cf;
  Reaction r;
  double slip = 0.0; // largest change of (soil − block) ux along the base over 0.3–0.75 s
};
// soil ux − block ux at 5 points of the base
std::vector<double> base_slip(const Model& m) {
  std::vector<double> out;
  const auto q = m.region_motion(0);
  for (double x : {kX0, 2.5, 3.0, 3.5, kX1}) out.push_back(m.displacement({x, kTop}).x - q.ux);
  return out;
}
Push push(double force) {
  Problem pb = layer_with_block(true);
  pb.local_damping = 0.7;
  pb.regions[0].force_x =
      TimeFunction::piecewise({{0.0, 0.0}, {0.3, 0.0}, {0.35, force}, {10.0, force}});
  Model m(pb);
  Push out;
  EXPECT_TRUE(m.initialise_gravity(true, 0.3 / 0.7, 1).converged) << m.log();
  std::vector<double> s0;
  while (m.time() < 0.75 - 1e-9) {
    EXPECT_TRUE(m.dynamic_step(0.01).converged) << m.log();
    if (s0.empty() && m.time() > 0.3 - 1e-9) s0 = base_slip(m);
    if (m.time() > 0.45 - 1e-9) out.ux.emplace_back(m.time(), m.region_motion(0).ux);
  }
  const auto s1 = base_slip(m);
  for (std::size_t k = 0; k < s1.size(); ++k)
    out.slip = std::max(out.slip, std::abs(s1[k] - s0[k]));
  out.cf = m.contact_force(0);
  out.r = m.soil_reaction(0);
  return out;
}
} // namespace

// Pushed horizontally by F = 0.3 W < μ_s W the block sticks: it stays put (its ux, ≈ 2.7e-4 m of
// soil shear, varies by < 1e-5 m over 0.45–0.75 s, still ringing; sliding at μ_d would move it by
// ≈ 0.1 m), no node slides at 0.75 s
// and the soil holds it with −F within 1 % (the base edges, where the soil's shear concentrates,
// slip by ~1e-4 m during the ramp: partial slip as in Cattaneo–Mindlin; printed). By F = 0.7 W >
// μ_s W it slides with the rigid-block acceleration (F − μ_d W)/M = 0.5 g (quadratic fit, within 1
// %), every base node sliding (the fixed-plane counterpart:
// ContinuumContact.BlockSlidesAboveStaticFriction).
TEST(ContinuumContactBody, PushedBlockSticksBelowAndSlidesAboveStaticFriction) {
  const Push below = push(0.3 * kWeight);
  const double a_below = fitted_acceleration(below.ux);
  std::printf("push 0.3 W: %d of %d nodes sliding, slip during the push %.2e m (since t = 0: "
              "%.2e m), block ux %.3e m, soil force x %.2f N/m (−F = %.2f), fitted acceleration "
              "%.2e m/s²\n",
              below.cf.sliding, below.cf.nodes, below.slip, below.cf.max_slip,
              below.ux.back().second, below.r.fx, -0.3 * kWeight, a_below);
  double lo = 1e300, hi = -1e300;
  for (const auto& [t, u] : below.ux) {
    lo = std::min(lo, u);
    hi = std::max(hi, u);
  }
  std::printf("push 0.3 W: block ux over 0.45–0.75 s varies by %.2e m\n", hi - lo);
  EXPECT_EQ(below.cf.sliding, 0);
  EXPECT_LT(hi - lo, 1e-5);
  EXPECT_NEAR(below.r.fx, -0.3 * kWeight, 0.01 * 0.3 * kWeight);

  const Push above = push(0.7 * kWeight);
  const double a = fitted_acceleration(above.ux), expected = (0.7 - kMuD) * kG;
  std::printf("push 0.7 W: %d of %d nodes sliding, fitted acceleration %.4f m/s² ((F − μ_d W)/M "
              "= %.4f, %+.2f %%), soil force (%.1f, %.1f) N/m (−μ_d W = %.1f)\n",
              above.cf.sliding, above.cf.nodes, a, expected, 100 * (a - expected) / expected,
              above.r.fx, above.r.fz, -kMuD * kWeight);
  EXPECT_NEAR(a, expected, 0.01 * expected);
  EXPECT_EQ(above.cf.sliding, above.cf.nodes);
  EXPECT_GT(above.cf.nodes, 0);
}

namespace {
// The block settled (0–0.3 s), then a counter-clockwise moment M ramped up over 0.3–0.6 s and held
// (e = M/W = 0.5 m > b/6: beyond the kern); the state at 1.2 s (local damping 0.7).
struct Rock {
  double rotation = 0, heel_gap = 0, heel_szz = -1e300, heel_depth = 0;
  int open = 0, nodes = 0;
};
Rock rock(bool contact) {
  Problem pb = layer_with_block(contact);
  pb.local_damping = 0.7;
  const double M = 0.5 * kWeight;
  pb.regions[0].moment = TimeFunction::piecewise({{0.0, 0.0}, {0.3, 0.0}, {0.6, M}, {10.0, M}});
  Model m(pb);
  Rock out;
  EXPECT_TRUE(m.initialise_gravity(true, 0.3 / 0.7, 1).converged) << m.log();
  while (m.time() < 1.2 - 1e-9) EXPECT_TRUE(m.dynamic_step(0.01).converged) << m.log();
  out.rotation = m.region_motion(0).rotation;
  out.heel_gap = -penetration(m, kX1); // the right edge rises under a counter-clockwise moment
  if (contact) {
    out.open = m.contact_force(0).open;
    out.nodes = m.contact_force(0).nodes;
  }
  // vertical soil stress at the Gauss point nearest below the heel (tension positive)
  double best = 1e300;
  for (const QpStress& s : m.stresses()) {
    if (s.material != 0) continue;
    const double d = std::hypot(s.x - (kX1 - 0.05), s.z - kTop);
    if (d < best) {
      best = d;
      out.heel_szz = s.szz;
      out.heel_depth = kTop - s.z;
    }
  }
  return out;
}
} // namespace

// Under a moment beyond the kern the contact footing lifts off on the heel side: some base nodes
// carry no force, the heel's gap opens (> 1e-5 m) and the soil below it is unloaded (σzz at the
// Gauss point nearest below the heel within 10 % of the mean base pressure W/b of its geostatic
// value −ρ g d); the tied footing keeps its heel on the soil (gap 0 to 1e-9 m) and pulls it in
// tension (σzz > 0). Without the soil's tension the contact footing rotates more.
TEST(ContinuumContactBody, FootingLiftsOffUnderAMomentWhereTheTiedOneCannot) {
  const Rock c = rock(true), t = rock(false);
  const double p = kWeight / kB;
  const double geostatic = -2000.0 * kG * c.heel_depth;
  std::printf("rocking: contact footing rotation %.4e rad, heel gap %.3e m, σzz below the heel "
              "%.1f Pa (geostatic %.1f Pa at %.3f m), %d open / %d in contact; tied footing "
              "rotation %.4e rad (%.2fx), heel gap %.1e m, σzz below the heel %.1f Pa (W/b = %.1f "
              "Pa)\n",
              c.rotation, c.heel_gap, c.heel_szz, geostatic, c.heel_depth, c.open, c.nodes,
              t.rotation, c.rotation / t.rotation, t.heel_gap, t.heel_szz, p);
  EXPECT_GT(c.open, 0);
  EXPECT_GT(c.nodes, 0);
  EXPECT_GT(c.heel_gap, 1e-5);
  EXPECT_LT(std::abs(c.heel_szz - geostatic), 0.1 * p);
  EXPECT_LT(std::abs(t.heel_gap), 1e-9);
  EXPECT_GT(t.heel_szz, 0.0);
  EXPECT_GT(c.rotation, t.rotation);
}

// Gravity-free impact: the free block, touching the free-floating layer (no boundary held),
// pushed down, sideways and turned by a force pulse (triangular, 0–0.02 s) then left alone until
// 0.5 s (it rebounds, slides and separates). After the pulse the linear and angular momentum of
// soil + block (Model::momentum) stay constant to 1e-9 of the pulse's impulse (the contact forces
// are equal and opposite with the same arms, the internal forces have no resultant or moment), and
// equal the impulse F·0.01 s within 1 % (vertical).
TEST(ContinuumContactBody, ImpactConservesMomentumOfBodyAndSoil) {
  Problem pb = layer_with_block(true, false);
  pb.left = pb.right = pb.bottom = pb.top = Bc::Free;
  const double F = 4.0e4;
  auto pulse = [](double a) {
    return TimeFunction::piecewise({{0.0, 0.0}, {0.01, a}, {0.02, 0.0}, {10.0, 0.0}});
  };
  pb.regions[0].force_x = pulse(0.5 * F);
  pb.regions[0].force_z = pulse(-F);
  pb.regions[0].moment = pulse(0.3 * F);
  Model m(pb);
  advance_to(m, 0.03);
  const Model::Momentum p0 = m.momentum();
  const double impulse = F * 0.01;
  double worst = 0.0;
  int open = 0, sliding = 0;
  while (m.time() < 0.5 - 1e-9) {
    ASSERT_TRUE(m.dynamic_step(0.01).converged) << m.log();
    const Model::Momentum p = m.momentum();
    worst = std::max(
        {worst, std::abs(p.px - p0.px), std::abs(p.pz - p0.pz), std::abs(p.angular - p0.angular)});
    open = std::max(open, m.contact_force(0).open);
    sliding = std::max(sliding, m.contact_force(0).sliding);
  }
  std::printf("impact: momentum after the pulse (%.6f, %.6f) kg·m/s/m, angular %.6f "
              "(impulse %.1f), largest change %.2e, at most %d nodes open, %d sliding\n",
              p0.px, p0.pz, p0.angular, impulse, worst, open, sliding);
  EXPECT_NEAR(p0.pz, -impulse, 0.01 * impulse);
  EXPECT_LT(worst, 1e-9 * impulse);
  EXPECT_GT(open, 0); // it did separate somewhere
}

// The foundation scene's DoF mode: x and z fixed, rotation free about the base centre. The block's
// weight goes to its support (not seated: the soil carries nothing at t = 0), so a moment M tilts
// it onto one half: at rest (1.2 s, local damping 0.7) ux = uz = 0 exactly, the soil's moment on it
// is −M within 1 %, and the lifted half's nodes are open.
TEST(ContinuumContactBody, PureRotationModeBalancesTheMoment) {
  Problem pb = layer_with_block(true);
  pb.local_damping = 0.7;
  pb.regions[0].mode[0] = pb.regions[0].mode[1] = Region::Mode::Fixed;
  const double M = 2.0e4;
  pb.regions[0].moment = TimeFunction::piecewise({{0.0, 0.0}, {0.2, M}, {10.0, M}});
  Model m(pb);
  ASSERT_TRUE(m.initialise_gravity(true, 0.3 / 0.7, 1).converged) << m.log();
  advance_to(m, 1.2);
  const auto q = m.region_motion(0);
  const Reaction r = m.soil_reaction(0);
  const ContactForce cf = m.contact_force(0);
  std::printf("pure rotation: rotation %.4e rad, ux %.1e, uz %.1e, soil moment %.2f N·m/m (−M = "
              "%.2f, %+.2e), %d in contact, %d open, heel gap %.3e m\n",
              q.rotation, q.ux, q.uz, r.moment, -M, (r.moment + M) / M, cf.nodes, cf.open,
              -penetration(m, kX1));
  EXPECT_EQ(q.ux, 0.0);
  EXPECT_EQ(q.uz, 0.0);
  EXPECT_GT(q.rotation, 0.0);
  EXPECT_NEAR(r.moment, -M, 0.01 * M);
  EXPECT_GT(cf.open, 0);
  EXPECT_GT(-penetration(m, kX1), 0.0);
}
