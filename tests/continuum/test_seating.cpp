// Seating (Region::seat, continuum.seat_structures): a rigid block embedded in an elastic layer,
// held vertically (dof_z fixed), starts resting on the soil under its own weight.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "fem.hpp"
#include "helpers.hpp"

using namespace demfem::continuum;
using namespace demfem::continuum::fem;

namespace {

constexpr double kWidth = 12.0, kHeight = 6.0;       // elastic layer [m]
constexpr double kBx0 = 5.0, kBx1 = 7.0, kBz0 = 4.0; // block: 2 m wide, base 2 m deep
constexpr double kRhoSoil = 1700.0, kRhoBlock = 5000.0, kG = 9.81, kK0 = 0.5;

Problem block_problem(bool seat, const std::string& integrator) {
  Problem pb;
  pb.mesh.dx = std::vector<double>(12, 1.0);
  pb.mesh.dz = std::vector<double>(6, 1.0);
  pb.mesh.refinement = 0;
  pb.mesh.domain = {{0, 0}, {kWidth, 0}, {kWidth, kHeight}, {0, kHeight}};
  pb.soil = demfem::test::elastic_soil(3.0e7, 0.3);
  pb.density = kRhoSoil;
  pb.gravity = kG;
  pb.integrator = integrator;
  Region r;
  r.name = "block";
  r.outline = {{kBx0, kBz0}, {kBx1, kBz0}, {kBx1, kHeight}, {kBx0, kHeight}};
  r.material.young = 1e12;
  r.material.poisson = 0.2;
  r.density = kRhoBlock;
  r.rigid = true;
  r.pivot = {0.5 * (kBx0 + kBx1), kBz0}; // base centre, as the rocking foundation
  r.load_point = r.pivot;
  r.mode[0] = Region::Mode::Fixed;
  r.mode[1] = Region::Mode::Fixed;
  r.mode[2] = Region::Mode::Free;
  r.seat = seat;
  pb.regions.push_back(r);
  return pb;
}

} // namespace

// Seated: at t = 0 the soil carries the block's weight W = ρ A g (static equilibrium with the
// vertical DoF free), the block then stays fixed there, and the first dynamic step of either
// integrator starts from that state (no jump in the soil force). Not seated: the K0 state holds
// only the overburden under the base, γ_soil · 2 m · 2 m ≈ 0.34 W, the rest goes into the
// constraint.
TEST(ContinuumSeating, EmbeddedBlockRestsOnTheSoilUnderItsWeight) {
  const double W = kRhoBlock * (kBx1 - kBx0) * (kHeight - kBz0) * kG;
  for (const std::string integrator : {"implicit", "explicit"}) {
    Model m(block_problem(true, integrator));
    ASSERT_TRUE(m.initialise_gravity(true, kK0, 1).converged) << m.log();
    ASSERT_EQ(m.seating().size(), 1U);
    const Seating& s = m.seating().front();
    const double fz0 = m.soil_reaction(0).fz;
    std::printf("seated (%s): settlement %.4g m, soil Fz %.6g N/m = %.5f W (seating log %.5f W)\n",
                integrator.c_str(), s.settlement, fz0, fz0 / W, s.soil_fz / s.weight);
    EXPECT_NEAR(s.weight, W, 1e-9 * W);
    EXPECT_GT(s.settlement, 0.0);
    EXPECT_NEAR(fz0, W, 0.01 * W) << integrator;
    EXPECT_NEAR(s.soil_fz, W, 0.01 * W) << integrator;
    // the block is fixed at the seated position: displacements restart from zero there
    EXPECT_EQ(m.region_motion(0).uz, 0.0);
    const StepStats st = m.dynamic_step(0.01);
    ASSERT_TRUE(st.converged) << m.log();
    const double fz1 = m.soil_reaction(0).fz;
    const double rot = m.region_motion(0).rotation;
    std::printf("  after one %s step of 0.01 s: soil Fz %.5f W, uz %.3g m, rotation %.3g rad\n",
                integrator.c_str(), fz1 / W, m.region_motion(0).uz, rot);
    EXPECT_NEAR(fz1, W, 0.01 * W) << integrator;
    EXPECT_EQ(m.region_motion(0).uz, 0.0);
    // at rest in equilibrium, symmetric, unloaded: it must not start rotating (the implicit
    // initial acceleration from the raw residual gave -6.2e-6 rad here)
    EXPECT_LT(std::abs(rot), 1e-9) << integrator;
  }
  Model off(block_problem(false, "implicit"));
  ASSERT_TRUE(off.initialise_gravity(true, kK0, 1).converged) << off.log();
  EXPECT_TRUE(off.seating().empty());
  const double fz = off.soil_reaction(0).fz;
  const double overburden = kRhoSoil * kG * (kHeight - kBz0) * (kBx1 - kBx0);
  std::printf("not seated: soil Fz %.6g N/m = %.4f W (overburden %.4f W)\n", fz, fz / W,
              overburden / W);
  EXPECT_GT(std::abs(fz - W), 0.3 * W); // far from resting on the soil
  EXPECT_NEAR(fz, overburden, 0.1 * overburden);
}

// The rocking foundation's set-up (foundation_rocking.toml, variant 2-A): a seated embedded block,
// x and z fixed, rotation free about its base centre under F = A·t·sin(ωt) at a point above the
// pivot. The explicit integrator (lumped mass, automatic step) and implicit Newmark (dt = 0.005 s)
// agree on the rotation history: RMS difference < 1 % of the peak rotation, peaks within 1 %
// (measured: 0.02 %).
// (0.5 Hz on a 12 m layer is quasi-static: the soil's first mode is ≈ 3.5 Hz.)
TEST(ContinuumSeating, RockingBlockUnderGrowingCyclicLoadExplicitMatchesImplicit) {
  const double omega = 3.141592653589793, A = 2.0e5, T = 2.0; // 0.5 Hz, one cycle
  std::vector<double> rot[2];
  const char* names[2] = {"explicit", "implicit"};
  for (int k = 0; k < 2; ++k) {
    Problem pb = block_problem(true, names[k]);
    pb.regions[0].force_x = demfem::scene::TimeFunction::t_sine(A, omega);
    pb.regions[0].load_point = {0.5 * (kBx0 + kBx1), kHeight};
    Model m(pb);
    ASSERT_TRUE(m.initialise_gravity(true, kK0, 1).converged) << m.log();
    const int n = 400;
    for (int s = 1; s <= n; ++s) {
      ASSERT_TRUE(m.dynamic_step(T / n).converged) << m.log();
      rot[k].push_back(m.region_motion(0).rotation);
    }
  }
  double peak = 0, peak_e = 0, peak_i = 0, sq = 0;
  for (std::size_t s = 0; s < rot[0].size(); ++s) {
    peak_e = std::max(peak_e, std::abs(rot[0][s]));
    peak_i = std::max(peak_i, std::abs(rot[1][s]));
    sq += (rot[0][s] - rot[1][s]) * (rot[0][s] - rot[1][s]);
  }
  peak = std::max(peak_e, peak_i);
  const double rms = std::sqrt(sq / double(rot[0].size()));
  std::printf("rocking block: peak rotation explicit %.4e rad, implicit %.4e rad; RMS difference "
              "%.2f %% of the peak\n",
              peak_e, peak_i, 100.0 * rms / peak);
  EXPECT_GT(peak, 1e-6); // it rocks
  EXPECT_LT(rms, 0.01 * peak);
  EXPECT_NEAR(peak_e, peak_i, 0.01 * peak);
}

namespace {
// The block of block_problem in zero-thickness Coulomb contact with the soil (Region::contact,
// continuum.structure_interface = "contact"): unmeshed, its base and both sides contact planes
// with μ_s/μ_D = 0.5/0.2, x and z fixed, rotation free (the rocking foundation's modes).
Problem contact_block_problem(bool seat) {
  Problem pb = block_problem(seat, "explicit");
  Region& r = pb.regions.front();
  r.contact = true;
  const Point a{kBx0, kHeight}, b{kBx0, kBz0}, c{kBx1, kBz0}, d{kBx1, kHeight};
  // the outline's order, as run.cpp's add_contact_planes: base, right side, left side (a node at
  // a corner keeps the first face's contact: the base's at both corners)
  for (const auto& [p, q] : {std::pair{b, c}, std::pair{c, d}, std::pair{a, b}}) {
    ContactPlane cp;
    cp.name = "block";
    cp.a = p;
    cp.b = q;
    cp.mu_static = 0.5;
    cp.mu_dynamic = 0.2;
    cp.region = 0;
    pb.contacts.push_back(cp);
  }
  return pb;
}
} // namespace

// A block in Coulomb contact is seated as the tied one: the nodes on its base stick to it while it
// translates down under its weight (it has no dofs of its own; one base node is the master), those
// on its sides are on rollers. The soil carries its weight W exactly (the contact reactions, within
// 1e-4 W), all of it through the base. From that state the explicit run starts at rest: over 0.3 s
// the soil's vertical force stays within 1 % of W and the block does not turn (< 1e-7 rad); with
// stuck sides during seating (the first version) the sides slid at the first step and the force
// dropped to 0.80 W. Not seated, the soil under it carries only the overburden (0.34 W).
TEST(ContinuumSeating, ContactBlockIsSeatedAsTheTiedOneAndStartsAtRest) {
  const double W = kRhoBlock * (kBx1 - kBx0) * (kHeight - kBz0) * kG;
  Model tied(block_problem(true, "explicit"));
  ASSERT_TRUE(tied.initialise_gravity(true, kK0, 1).converged) << tied.log();
  ASSERT_EQ(tied.seating().size(), 1U);
  Model m(contact_block_problem(true));
  ASSERT_TRUE(m.initialise_gravity(true, kK0, 1).converged) << m.log();
  ASSERT_EQ(m.seating().size(), 1U);
  const Seating& s = m.seating().front();
  const double fz0 = m.soil_reaction(0).fz;
  std::printf("contact block seated: settlement %.6g m (tied %.6g m), soil Fz %.8g N/m = %.6f W "
              "(seating log %.6f W)\n",
              s.settlement, tied.seating().front().settlement, fz0, fz0 / W, s.soil_fz / W);
  EXPECT_NEAR(s.weight, W, 1e-9 * W);
  EXPECT_GT(s.settlement, 0.0);
  // frictionless sides while it settles: the base alone carries W, so it settles more than the
  // tied block, whose sides are bonded (measured: 0.003168 against 0.002690 m)
  const double tied_settlement = tied.seating().front().settlement;
  EXPECT_GT(s.settlement, 1.05 * tied_settlement);
  EXPECT_LT(s.settlement, 1.5 * tied_settlement);
  EXPECT_NEAR(fz0, W, 1e-4 * W);
  EXPECT_NEAR(s.soil_fz, W, 1e-4 * W);
  EXPECT_NEAR(m.contact_force(0).fz, W, 1e-4 * W); // the base
  for (std::size_t k : {1U, 2U}) {                 // the sides: the K0 pressure, no shear
    EXPECT_LT(std::abs(m.contact_force(k).fz), 1e-6 * W);
    EXPECT_GT(m.contact_force(k).normal, 0.0);
  }
  EXPECT_EQ(m.region_motion(0).uz, 0.0);
  double worst = 0.0, turn = 0.0;
  while (m.time() < 0.3 - 1e-9) {
    ASSERT_TRUE(m.dynamic_step(0.01).converged) << m.log();
    worst = std::max(worst, std::abs(m.soil_reaction(0).fz - W));
    turn = std::max(turn, std::abs(m.region_motion(0).rotation));
  }
  std::printf("  explicit run to 0.3 s: largest |Fz − W| %.3e W, largest rotation %.3e rad\n%s",
              worst / W, turn, m.contact_body_summary().c_str());
  EXPECT_LT(worst, 0.01 * W);
  EXPECT_LT(turn, 1e-7);

  Model off(contact_block_problem(false));
  ASSERT_TRUE(off.initialise_gravity(true, kK0, 1).converged) << off.log();
  EXPECT_TRUE(off.seating().empty());
  const double overburden = kRhoSoil * kG * (kHeight - kBz0) * (kBx1 - kBx0);
  const double fz_off = off.soil_reaction(0).fz;
  std::printf("contact block not seated: soil Fz %.4f W (overburden %.4f W)\n", fz_off / W,
              overburden / W);
  EXPECT_NEAR(fz_off, overburden, 0.1 * overburden);
}
