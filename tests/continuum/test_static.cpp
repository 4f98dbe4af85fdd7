// Static verification problems of the plane-strain solver against closed forms.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include "constitutive/k0.hpp"
#include "demfem/continuum/verification.hpp"
#include "fem.hpp"
#include "helpers.hpp"

using namespace demfem::continuum;
using namespace demfem::continuum::fem;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<double> uniform(double length, int n) {
  return std::vector<double>(n, length / n);
}

using demfem::continuum::graded;

using demfem::test::elastic_soil;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace

// Laterally confined elastic column under gravity: σzz = −ρg(H − z), σxx = ν/(1−ν) σzz
// (one-dimensional compression, e.g. Timoshenko & Goodier).
TEST(ContinuumStatic, GravityColumn) {
  Problem pb;
  const double H = 10.0, rho = 1700.0, g = 9.81, nu = 0.3;
  pb.mesh.dx = {1.0};
  pb.mesh.dz = uniform(H, 10);
  pb.mesh.refinement = 1;
  pb.soil = elastic_soil(3.0e7, nu);
  pb.density = rho;
  pb.gravity = g;
  Model m(pb);
  const StepStats st = m.initialise_gravity(false, 0.0, 1);
  ASSERT_TRUE(st.converged);
  double worst = 0.0;
  for (const QpStress& s : m.stresses()) {
    const double szz = -rho * g * (H - s.z);
    const double sxx = nu / (1 - nu) * szz;
    const double tol = 0.01 * std::abs(szz) + 1e-9 * rho * g * H;
    EXPECT_NEAR(s.szz, szz, tol);
    EXPECT_NEAR(s.sxx, sxx, tol);
    EXPECT_NEAR(s.syy, sxx, tol);
    worst = std::max(
        {worst, std::abs(s.szz - szz) / (rho * g * H), std::abs(s.sxx - sxx) / (rho * g * H)});
  }
  std::printf("gravity column: dofs=%zu max |error|/(ρgH) = %.2e\n", m.n_dofs(), worst);
}

// Flamant strip load on an elastic half-plane (Poulos & Davis 1974, strip of half-width b):
// settlement(centre) − settlement(edge) = (4 ln 2/π)(1 − ν²) q b / E. The problem and its closed
// form live in continuum/run/verification.cpp (shared with `demfem study error-vs-time flamant`).
TEST(ContinuumStatic, FlamantStripLoad) {
  double prev_err = 0.0;
  for (int r = 0; r <= 2; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto f = demfem::continuum::flamant_strip_load(r, 2);
    EXPECT_TRUE(f.converged);
    const double err = std::abs(f.computed - f.exact) / f.exact;
    std::printf("flamant refinement %d: dofs=%zu Δs=%.6e m (exact %.6e) rel.err=%.3e rate=%.2f "
                "wall=%.2fs\n",
                r, f.dofs, f.computed, f.exact, err, r > 0 ? std::log2(prev_err / err) : 0.0,
                seconds_since(t0));
    prev_err = err;
    if (r == 2) {
      EXPECT_LT(err, 0.03);
    }
  }
}

// Rigid rough strip footing on weightless undrained clay (φ = 0): limit pressure (2 + π)c
// (Prandtl 1920).
namespace {
double footing_limit_pressure(int degree, int refinement, double growth) {
  const double B = 1.0, c = 1.0e4;
  Problem pb = demfem::test::undrained_half_space(B, c, growth);
  pb.degree = degree;
  pb.mesh.refinement = refinement;
  Patch footing;
  footing.name = "footing";
  footing.a = {0.0, 0.0};
  footing.b = {0.5 * B, 0.0};
  footing.uz = -0.03 * B;
  pb.patches.push_back(footing);
  Model m(pb);
  const auto t0 = std::chrono::steady_clock::now();
  const int steps = 30;
  double q = 0.0;
  int newton = 0, linear = 0;
  for (int k = 1; k <= steps; ++k) {
    const StepStats st = m.static_step(double(k) / steps);
    EXPECT_TRUE(st.converged) << "step " << k << "\n" << m.log();
    if (!st.converged) return 0.0;
    newton += st.newton_iterations;
    linear += st.linear_iterations;
    q = -m.reaction(0).fz / (0.5 * B);
    if (k % 10 == 0)
      std::printf("  footing p=%d r=%d settlement/B=%.3f q/c=%.4f\n", degree, refinement,
                  0.03 * k / steps, q / c);
  }
  const double exact = (2.0 + kPi) * c;
  std::printf("footing p=%d r=%d: dofs=%zu q/c=%.4f (exact %.4f) rel.err=%.3e newton=%d linear=%d "
              "wall=%.2fs\n",
              degree, refinement, m.n_dofs(), q / c, exact / c, (q - exact) / exact, newton, linear,
              seconds_since(t0));
  return q / c;
}
} // namespace

// Rigid rough strip footing on weightless undrained clay (φ = 0): limit pressure (2 + π)c
// (Prandtl 1920), within 5 %. Default degree 2 with B-bar (without B-bar the same mesh gives
// +6.1 %: isochoric plastic flow locks Q2 with full integration).
TEST(ContinuumStatic, StripFootingUndrainedBearingCapacity) {
  const double q = footing_limit_pressure(2, 0, 1.3);
  EXPECT_NEAR(q, 2.0 + kPi, 0.05 * (2.0 + kPi));
}

TEST(ContinuumStaticLong, StripFootingUndrainedBearingCapacityDegree3) {
  const double q = footing_limit_pressure(3, 0, 1.3);
  EXPECT_NEAR(q, 2.0 + kPi, 0.05 * (2.0 + kPi));
}

TEST(ContinuumStaticLong, StripFootingUndrainedBearingCapacityRefined) {
  const double q = footing_limit_pressure(2, 1, 1.3);
  EXPECT_NEAR(q, 2.0 + kPi, 0.05 * (2.0 + kPi));
}

// Smooth wall moving away from a cohesionless Mohr–Coulomb backfill: Rankine active thrust
// P = ½ K_a γ H², K_a = (1 − sin φ)/(1 + sin φ) (Rankine 1857).
TEST(ContinuumStatic, RankineActiveThrust) {
  Problem pb;
  const double H = 5.0, phi = 30.0 * kPi / 180.0, rho = 1700.0, g = 9.81;
  pb.mesh.dx = uniform(H, 10);
  pb.mesh.dz = uniform(H, 10);
  pb.soil = demfem::test::mohr_coulomb_soil(3.0e7, 0.3, phi, 0.0);
  pb.density = rho;
  pb.gravity = g;
  pb.bottom = Bc::Roller;
  Patch wall;
  wall.name = "wall";
  wall.a = {0.0, 0.0};
  wall.b = {0.0, H};
  wall.constrain_z = false; // smooth
  wall.ux = -0.004 * H;
  pb.patches.push_back(wall);
  Model m(pb);
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(m.initialise_gravity(true, constitutive::jaky_k0(phi), 1).converged);
  const double at_rest = m.reaction(0).fx;
  const int steps = 20;
  int newton = 0;
  double half = 0.0;
  for (int k = 1; k <= steps; ++k) {
    const StepStats st = m.static_step(double(k) / steps);
    ASSERT_TRUE(st.converged) << "step " << k << "\n" << m.log();
    newton += st.newton_iterations;
    if (k % 5 == 0)
      std::printf("  rankine wall displacement/H=%.4f thrust=%.1f N/m\n", 0.004 * k / steps,
                  m.reaction(0).fx);
    if (k == steps / 2) half = m.reaction(0).fx;
  }
  const double thrust = m.reaction(0).fx;
  const double Ka = (1 - std::sin(phi)) / (1 + std::sin(phi));
  const double exact = 0.5 * Ka * rho * g * H * H;
  std::printf("rankine: dofs=%zu at-rest=%.1f N/m thrust=%.1f N/m (exact %.1f) rel.err=%.3e "
              "newton=%d wall=%.2fs\n",
              m.n_dofs(), at_rest, thrust, exact, (thrust - exact) / exact, newton,
              seconds_since(t0));
  EXPECT_NEAR(thrust, exact, 0.05 * exact);
  EXPECT_NEAR(half, thrust, 0.01 * thrust) << "thrust has not reached a plateau";
}

// Rigid smooth strip footing rocking on an elastic half-plane: K_r = M/θ = πGB²/(8(1−ν)) per
// metre (Gazetas 1991, strip of width B).
TEST(ContinuumStatic, StripFootingRockingStiffness) {
  Problem pb;
  const double B = 2.0, L = 100.0, E = 2.0e7, nu = 0.3, theta = 1.0e-4;
  std::vector<double> half = graded(B, 0.125, L, 1.35);
  pb.mesh.x0 = -L;
  pb.mesh.z0 = -L;
  pb.mesh.dx.assign(half.rbegin(), half.rend());
  pb.mesh.dx.insert(pb.mesh.dx.end(), half.begin(), half.end());
  pb.mesh.dz.assign(half.rbegin(), half.rend());
  pb.soil = elastic_soil(E, nu);
  pb.gravity = 0.0;
  Patch footing;
  footing.name = "footing";
  footing.a = {-0.5 * B, 0.0};
  footing.b = {0.5 * B, 0.0};
  footing.constrain_x = false; // smooth contact
  footing.rotation = theta;
  footing.pivot = {0.0, 0.0};
  pb.patches.push_back(footing);
  Model m(pb);
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(m.static_step(1.0).converged);
  // the footing does positive work on the soil: the moment it applies is +Kθ
  const double K = m.reaction(0).moment / theta;
  const double G = E / (2 * (1 + nu));
  const double exact = kPi * G * B * B / (8 * (1 - nu));
  std::printf("rocking: dofs=%zu K=%.5e N·m/rad/m (exact %.5e) rel.err=%.3e wall=%.2fs\n",
              m.n_dofs(), K, exact, (K - exact) / exact, seconds_since(t0));
  EXPECT_NEAR(K, exact, 0.05 * exact);
}

// Stress-dependent modulus (constitutive/elastic.hpp): a laterally confined column whose E follows
// (p/p_ref)^n of the K0 stresses, loaded by a surface pressure q, settles by
// ∫ q / (M_ref f(s)) ds over the depth s, M_ref = E(1 − ν)/((1 + ν)(1 − 2ν)) the constrained
// modulus and f(s) = (max(c s, p_min)/p_ref)^n, c s = ρ g s (1 + K0)/2 the in-plane mean stress
// (one-dimensional compression). With s_min = p_min/c:
// ∫0^H ds/f = s_min (p_ref/p_min)^n + (p_ref/c)^n (H^{1−n} − s_min^{1−n})/(1 − n).
TEST(ContinuumStatic, ColumnWithStressDependentModulusSettlesAsTheIntegralOfItsCompliance) {
  const double H = 10.0, rho = 2000.0, g = 9.81, nu = 0.3, E = 2.0e7, q = 2.0e4;
  const double k0 = nu / (1.0 - nu); // the elastic column's own K0: no correction on top
  const double Mref = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu));
  auto settle = [&](double n) {
    Problem pb;
    pb.mesh.dx = {1.0};
    pb.mesh.dz = uniform(H, 20);
    pb.mesh.refinement = 1;
    constitutive::Elastic::Parameters soil;
    soil.young = E;
    soil.poisson = nu;
    soil.modulus_exponent = n;
    soil.modulus_reference_stress = 5.0e4;
    soil.modulus_min_stress = 2.0e3;
    pb.soil = constitutive::Material(constitutive::Elastic(soil));
    pb.density = rho;
    pb.gravity = g;
    pb.tractions.push_back({{0.0, H}, {1.0, H}, q});
    Model m(pb);
    EXPECT_TRUE(m.initialise_gravity(true, k0, 1).converged);
    EXPECT_TRUE(m.static_step(1.0).converged);
    return -m.displacement({0.5, H}).z;
  };
  const double c = rho * g * (1 + k0) / 2, pref = 5.0e4, pmin = 2.0e3;
  for (const double n : {0.0, 0.5}) {
    const double smin = pmin / c;
    const double integral =
        n == 0.0
            ? H
            : smin * std::pow(pref / pmin, n) +
                  std::pow(pref / c, n) * (std::pow(H, 1 - n) - std::pow(smin, 1 - n)) / (1 - n);
    const double exact = q / Mref * integral;
    const double got = settle(n);
    std::printf("column, E ∝ p^%.1f: settlement %.6e m, closed form %.6e m\n", n, got, exact);
    EXPECT_NEAR(got, exact, 0.01 * exact) << "n = " << n;
  }
}
