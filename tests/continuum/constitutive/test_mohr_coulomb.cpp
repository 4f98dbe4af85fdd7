// Mohr–Coulomb return mapping: admissibility, consistency, flow direction, consistent tangent
// (against central finite differences) in every return region; the dilatancy cut-off.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <set>

#include "constitutive/mohr_coulomb.hpp"
#include "constitutive/registry.hpp"

using namespace demfem::continuum::constitutive;
using namespace demfem::continuum::constitutive::mohr_coulomb;

namespace {

constexpr double kPi = 3.14159265358979323846;

const Hooke kElastic{2.0e7, 0.3};

Strength soil(double tension = -1.0) {
  Strength p;
  p.friction = 30.0 * kPi / 180.0;
  p.cohesion = 1.0e4;
  p.dilation = 10.0 * kPi / 180.0;
  p.tension_cutoff = tension;
  return p;
}

Result integrate(const Strength& p, const ElasticStrain& trial) {
  return mohr_coulomb::integrate(kElastic, p, trial);
}

// trial elastic strain from in-plane principal strains rotated by θ and the out-of-plane strain
ElasticStrain trial(double ea, double eb, double eyy, double theta) {
  const double c = std::cos(theta), s = std::sin(theta);
  ElasticStrain e;
  e.in_plane = {{ea * c * c + eb * s * s, ea * s * s + eb * c * c, 2.0 * (ea - eb) * c * s}};
  e.out_of_plane = eyy;
  return e;
}

void principal(const Result& r, double s[3]) {
  const double m = 0.5 * (r.stress[0] + r.stress[1]);
  const double d = std::hypot(0.5 * (r.stress[0] - r.stress[1]), r.stress[2]);
  s[0] = m + d;
  s[1] = m - d;
  s[2] = r.stress_yy;
  std::sort(s, s + 3, [](double a, double b) { return a > b; });
}

// admissible: on or inside the MC surface and the cut-off; consistent: re-integrating the
// returned elastic strain is elastic and gives the same stress
void check_admissible(const Strength& p, const ElasticStrain& tr) {
  const Result r = integrate(p, tr);
  double s[3];
  principal(r, s);
  const double scale = std::abs(s[0]) + std::abs(s[2]) + p.cohesion;
  EXPECT_LE(yield(p, s[0], s[2]), 1e-8 * scale);
  if (p.tension_cutoff >= 0) {
    EXPECT_LE(s[0], p.tension_cutoff + 1e-8 * scale);
  }
  if (r.region != Return::Elastic) {
    // on the surface: the main plane or the cut-off is active
    const double f =
        std::max(yield(p, s[0], s[2]), p.tension_cutoff >= 0 ? s[0] - p.tension_cutoff : -1e300);
    EXPECT_NEAR(f, 0.0, 1e-8 * scale);
  }
  const Result again = integrate(p, r.elastic);
  EXPECT_EQ(again.region, Return::Elastic);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(again.stress[k], r.stress[k], 1e-8 * scale);
}

// consistent tangent vs central differences of the integrated stress
void check_tangent(const Strength& p, const ElasticStrain& tr, Return expected) {
  const Result r = integrate(p, tr);
  ASSERT_EQ(r.region, expected);
  const double h = 1e-9;
  double maxerr = 0.0, maxval = 0.0;
  for (int j = 0; j < 3; ++j) {
    ElasticStrain a = tr, b = tr;
    a.in_plane[j] += h;
    b.in_plane[j] -= h;
    const Result ra = integrate(p, a), rb = integrate(p, b);
    ASSERT_EQ(ra.region, expected);
    ASSERT_EQ(rb.region, expected);
    for (int i = 0; i < 3; ++i) {
      const double fd = (ra.stress[i] - rb.stress[i]) / (2 * h);
      maxerr = std::max(maxerr, std::abs(fd - r.tangent[i][j]));
      maxval = std::max(maxval, std::abs(r.tangent[i][j]));
    }
  }
  EXPECT_LE(maxerr, 1e-5 * maxval + 1e-6) << "tangent mismatch";
}

} // namespace

TEST(MohrCoulomb, ElasticBelowYield) {
  const Strength p = soil();
  const ElasticStrain tr = trial(-1e-5, -2e-5, -1.5e-5, 0.3);
  const Result r = integrate(p, tr);
  EXPECT_EQ(r.region, Return::Elastic);
  Voigt s;
  double syy;
  elastic_stress(kElastic, tr, s, syy);
  for (int k = 0; k < 3; ++k) EXPECT_DOUBLE_EQ(r.stress[k], s[k]);
  const VoigtMatrix D = elastic_tangent(kElastic);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(r.tangent[i][j], D[i][j], 1e-6 * D[0][0]);
  check_tangent(p, tr, Return::Elastic);
}

TEST(MohrCoulomb, MainPlaneReturnAndFlowDirection) {
  const Strength p = soil();
  const ElasticStrain tr = trial(2e-3, -3e-3, -0.5e-3, 0.4);
  const Result r = integrate(p, tr);
  ASSERT_EQ(r.region, Return::MainPlane);
  check_admissible(p, tr);
  check_tangent(p, tr, Return::MainPlane);
  // plastic strain increment Δεp = εe_trial − εe_new is along N = (1+sin ψ, 0, −(1−sin ψ))
  // in the (major, intermediate, minor) principal frame (non-associated flow)
  const double c = std::cos(0.4), s = std::sin(0.4);
  auto along = [&](const ElasticStrain& e, double ux, double uz) {
    return e.in_plane[0] * ux * ux + e.in_plane[1] * uz * uz + e.in_plane[2] * ux * uz;
  };
  const double dp1 = along(tr, c, s) - along(r.elastic, c, s);   // major (tensile) direction
  const double dp3 = along(tr, -s, c) - along(r.elastic, -s, c); // minor direction
  const double dpy = tr.out_of_plane - r.elastic.out_of_plane;
  const double spsi = std::sin(p.dilation);
  EXPECT_NEAR(dp3 / dp1, -(1 - spsi) / (1 + spsi), 1e-8);
  EXPECT_NEAR(dpy / dp1, 0.0, 1e-8);
}

TEST(MohrCoulomb, EdgeReturns) {
  const Strength p = soil();
  // σ1 > σ2 ≈ σ3 (triaxial compression): the return lands on the σ2 = σ3 edge
  const ElasticStrain compression = trial(3e-3, -2e-3, -1.98e-3, 0.2);
  // σ1 ≈ σ2 > σ3 (triaxial extension): the σ1 = σ2 edge
  const ElasticStrain extension = trial(1e-3, -2e-3, 0.98e-3, 0.7);
  const Result a = integrate(p, compression), b = integrate(p, extension);
  EXPECT_EQ(a.region, Return::EdgeRight);
  EXPECT_EQ(b.region, Return::EdgeLeft);
  check_admissible(p, compression);
  check_admissible(p, extension);
  check_tangent(p, compression, Return::EdgeRight);
  check_tangent(p, extension, Return::EdgeLeft);
  double s[3];
  principal(a, s);
  EXPECT_NEAR(s[1], s[2], 1e-8 * std::abs(s[2]));
  principal(b, s);
  EXPECT_NEAR(s[0], s[1], 1e-8 * std::abs(s[2]));
}

TEST(MohrCoulomb, ApexReturn) {
  const Strength p = soil();
  const ElasticStrain tr = trial(3e-3, 2e-3, 2.5e-3, 0.1);
  const Result r = integrate(p, tr);
  ASSERT_EQ(r.region, Return::Apex);
  const double apex = p.cohesion / std::tan(p.friction); // p = c cot φ
  EXPECT_NEAR(r.stress[0], apex, 1e-8 * apex);
  EXPECT_NEAR(r.stress[1], apex, 1e-8 * apex);
  EXPECT_NEAR(r.stress_yy, apex, 1e-8 * apex);
  check_admissible(p, tr);
  check_tangent(p, tr, Return::Apex);
}

TEST(MohrCoulomb, TensionCutOff) {
  const Strength p = soil(5.0e3);
  const ElasticStrain tr = trial(1.0e-3, -0.2e-3, -0.1e-3, 0.5);
  const Result r = integrate(p, tr);
  EXPECT_TRUE(r.region == Return::Tension || r.region == Return::TensionMain) << int(r.region);
  check_admissible(p, tr);
  check_tangent(p, tr, r.region);
  double s[3];
  principal(r, s);
  EXPECT_NEAR(s[0], p.tension_cutoff, 1e-6 * p.cohesion);
}

TEST(MohrCoulomb, TrescaLimitWhenFrictionless) {
  Strength p = soil();
  p.friction = 0.0;
  p.dilation = 0.0;
  const ElasticStrain tr = trial(3e-3, -3e-3, 0.0, 0.25);
  const Result r = integrate(p, tr);
  double s[3];
  principal(r, s);
  EXPECT_NEAR(s[0] - s[2], 2 * p.cohesion, 1e-8 * p.cohesion); // Tresca: σ1 − σ3 = 2c
  check_tangent(p, tr, r.region);
}

TEST(MohrCoulomb, RandomTrialsAdmissibleInAllRegions) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-4e-3, 4e-3), ang(0.0, kPi);
  std::set<int> regions;
  for (const double t : {-1.0, 5.0e3}) {
    const Strength p = soil(t);
    for (int k = 0; k < 4000; ++k) {
      const ElasticStrain tr = trial(u(rng), u(rng), u(rng), ang(rng));
      regions.insert(int(integrate(p, tr).region));
      check_admissible(p, tr);
      if (HasFailure()) return;
    }
  }
  for (Return r : {Return::Elastic, Return::MainPlane, Return::EdgeLeft, Return::EdgeRight,
                   Return::Apex, Return::Tension, Return::TensionMain, Return::TensionEdge})
    EXPECT_TRUE(regions.count(int(r))) << "region never reached: " << int(r);
}

// Dilatancy cut-off (MohrCoulomb::update): drained simple shear at constant σzz. Without the
// cut-off ψ = 10° dilates for ever (dε_v^p/dγ^p = sin ψ); with it the plastic volumetric strain
// stops within one increment of the cut-off and shearing goes on at constant volume, on the same
// Mohr–Coulomb strength.
TEST(MohrCoulomb, DilatancyCutOffStopsDilation) {
  auto shear = [](double cutoff) {
    Elastic::Parameters e;
    e.young = kElastic.young;
    e.poisson = kElastic.poisson;
    MohrCoulomb::Parameters p;
    p.friction_angle = soil().friction;
    p.dilation_angle = soil().dilation;
    p.dilation_cutoff = cutoff;
    const Material m{MohrCoulomb(e, p)};
    State c = m.initial_state();
    const double s0 = -1.0e5; // isotropic compression [Pa]
    c.stress = {{s0, s0, 0.0}};
    c.syy = s0;
    m.set_stress(c);
    double max_step_dev = 0.0;
    for (int k = 0; k < 3000; ++k) { // γ to 0.3 in steps of 1e-4
      Voigt d{{0.0, 0.0, 1e-4}};
      State s;
      VoigtMatrix t{};
      for (int it = 0; it < 20; ++it) { // Δεzz such that σzz stays s0 (drained, free surface)
        m.update(c, d, s, &t);
        if (std::abs(s.stress[1] - s0) < 1e-6 * std::abs(s0)) break;
        d[1] -= (s.stress[1] - s0) / t[1][1];
      }
      max_step_dev = std::max(max_step_dev, std::abs(s.stress[1] - s0));
      c = s;
    }
    EXPECT_LT(max_step_dev, 1e-3 * std::abs(s0));
    return std::pair{
        MohrCoulomb::plastic_volumetric_strain(std::get<MohrCoulomb::Internal>(c.internal)),
        c.stress[2]};
  };
  const auto [ev_free, tau_free] = shear(std::numeric_limits<double>::infinity());
  const auto [ev_cut, tau_cut] = shear(0.01);
  EXPECT_GT(ev_free, 0.04); // ≈ γ^p sin ψ / (…): far beyond the cut-off
  EXPECT_GE(ev_cut, 0.01);
  EXPECT_LT(ev_cut, 0.0101); // one increment of 1e-4 shear adds < 2e-5
  // both on the yield surface: the shear stress stays of the same order (σxx differs)
  EXPECT_GT(std::abs(tau_cut), 0.2e5);
  EXPECT_GT(std::abs(tau_free), 0.2e5);
}
