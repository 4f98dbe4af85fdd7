// Coarse-graining: closed-form checks of the kernel averaging.
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "demfem/compare/coarse_grain.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/dem/state.hpp"

using namespace demfem;

TEST(CoarseGrain, LucyKernelIntegratesToOne) {
  const double c = 0.7;
  double sum = 0.0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) { // ∫ φ 2πr dr by the midpoint rule
    const double r = (k + 0.5) * c / n;
    sum += compare::lucy_kernel(r, c) * 2.0 * std::numbers::pi * r * c / n;
  }
  EXPECT_NEAR(sum, 1.0, 1e-8);
  EXPECT_EQ(compare::lucy_kernel(c, c), 0.0);
  EXPECT_EQ(compare::lucy_kernel(2 * c, c), 0.0);
}

// A square lattice (spacing d) whose contacts carry the forces of a uniform stress state
// σ_xx = −p, σ_zz = −q, σ_xz = τ: each horizontal contact f = (−p d, τ d) on the left particle
// from the right one, each vertical contact f = (τ d, −q d) on the lower from the upper
// (σ = Σ f ⊗ l / A with one contact of each kind per cell of area d²). The kernel average must
// give the uniform state back away from the lattice's edge.
TEST(CoarseGrain, UniformStressIsRecovered) {
  const double d = 0.1, p = 3.0e4, q = 5.0e4, tau = 1.0e4;
  const int n = 40;
  compare::CgParticles parts;
  std::vector<compare::CgContact> contacts;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      parts.x.push_back(i * d);
      parts.z.push_back(j * d);
      parts.mass.push_back(1.0);
      if (i + 1 < n) contacts.push_back({i * d, j * d, (i + 1) * d, j * d, -p * d, tau * d});
      if (j + 1 < n) contacts.push_back({i * d, j * d, i * d, (j + 1) * d, tau * d, -q * d});
    }
  compare::Grid g;
  g.x0 = g.z0 = 0.0;
  g.h = 0.05;
  g.nx = g.nz = 79;
  const double c = 2.0 * d; // two particle diameters
  const auto f = compare::coarse_grain(parts, contacts, g, c);
  int checked = 0;
  for (int k = 0; k < g.nz; ++k)
    for (int i = 0; i < g.nx; ++i) {
      const double x = g.x(i), z = g.z(k);
      if (x < c + d || x > (n - 1) * d - c - d || z < c + d || z > (n - 1) * d - c - d) continue;
      const auto a = g.at(i, k);
      EXPECT_NEAR(f.sxx[a], -p, 0.01 * p) << x << " " << z;
      EXPECT_NEAR(f.szz[a], -q, 0.01 * q) << x << " " << z;
      EXPECT_NEAR(f.sxz[a], tau, 0.01 * q) << x << " " << z;
      ++checked;
    }
  EXPECT_GT(checked, 500);
}

// Particles at random positions displaced by u = A x + b: the affine fit gives u and its gradient
// exactly at every node with enough particles in reach.
TEST(CoarseGrain, LinearDisplacementGivesItsStrain) {
  const double a11 = 0.01, a12 = -0.004, a21 = 0.006, a22 = -0.02, b1 = 0.3, b2 = -0.1;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(0.0, 4.0);
  compare::CgParticles parts;
  for (int k = 0; k < 1500; ++k) {
    const double x = U(rng), z = U(rng);
    parts.x.push_back(x);
    parts.z.push_back(z);
    parts.mass.push_back(0.5 + 0.25 * U(rng));
    parts.ux.push_back(a11 * x + a12 * z + b1);
    parts.uz.push_back(a21 * x + a22 * z + b2);
  }
  compare::Grid g;
  g.x0 = g.z0 = 0.5;
  g.h = 0.25;
  g.nx = g.nz = 13;
  const auto f = compare::coarse_grain(parts, {}, g, 0.4);
  int checked = 0;
  for (int k = 0; k < g.nz; ++k)
    for (int i = 0; i < g.nx; ++i) {
      const auto n = g.at(i, k);
      ASSERT_TRUE(std::isfinite(f.exx[n]));
      EXPECT_NEAR(f.ux[n], a11 * g.x(i) + a12 * g.z(k) + b1, 1e-9);
      EXPECT_NEAR(f.uz[n], a21 * g.x(i) + a22 * g.z(k) + b2, 1e-9);
      EXPECT_NEAR(f.exx[n], a11, 1e-9);
      EXPECT_NEAR(f.ezz[n], a22, 1e-9);
      EXPECT_NEAR(f.exz[n], 0.5 * (a12 + a21), 1e-9);
      EXPECT_NEAR(f.vol[n], a11 + a22, 1e-9);
      EXPECT_NEAR(f.rotation[n], 0.5 * (a21 - a12), 1e-9);
      ++checked;
    }
  EXPECT_EQ(checked, 169);
}

// The kernel neither creates nor loses mass or momentum: the coarse-grained density and momentum
// integrated over a grid covering every particle's kernel equal Σ m and Σ m v.
TEST(CoarseGrain, MassAndMomentumAreConserved) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  compare::CgParticles parts;
  double m = 0, px = 0, pz = 0;
  for (int k = 0; k < 300; ++k) {
    parts.x.push_back(1.0 + 2.0 * U(rng));
    parts.z.push_back(1.0 + 1.5 * U(rng));
    parts.mass.push_back(1.0 + U(rng));
    parts.vx.push_back(U(rng) - 0.3);
    parts.vz.push_back(2.0 * U(rng) - 1.0);
    m += parts.mass.back();
    px += parts.mass.back() * parts.vx.back();
    pz += parts.mass.back() * parts.vz.back();
  }
  const double c = 0.3;
  compare::Grid g;
  g.x0 = g.z0 = 0.0;
  g.h = c / 10.0;
  g.nx = static_cast<int>(4.0 / g.h) + 1;
  g.nz = static_cast<int>(3.5 / g.h) + 1;
  const auto f = compare::coarse_grain(parts, {}, g, c);
  double M = 0, PX = 0, PZ = 0;
  for (std::size_t n = 0; n < g.size(); ++n) { // Σ h² (a Riemann sum of the integral)
    M += f.density[n] * g.h * g.h;
    PX += f.px[n] * g.h * g.h;
    PZ += f.pz[n] * g.h * g.h;
  }
  EXPECT_NEAR(M, m, 2e-3 * m);
  EXPECT_NEAR(PX, px, 2e-3 * m);
  EXPECT_NEAR(PZ, pz, 2e-3 * m);
}

// A column of N disks (radius r, weight w each) resting on a floor at z = 0, its contact forces
// written by the DEM's force-chain writer and read back by the coarse-grainer (kernel support
// c = 2 diameters, the comparison's default). Statics: the contact below disk k carries (N − k) w.
// Closed forms (Weinhart et al. 2012, with the boundary term):
//  - ∫∫ σ_zz dA = Σ_c f_z l_z = −w r N² (= −g Σ m_i z_i, the virial of the weights); without the
//    floor contact it would be −w r N(N − 1), 1/N short;
//  - ∫ σ_zz dx across the section through disk k's centre = −(N − k − ½) w, the weight above the
//    section (the carried force is a staircase stepping down by w at every centre; a symmetric
//    kernel that stays inside the column averages each step), for kernels clear of both ends.
TEST(CoarseGrain, ColumnOnFloorCarriesItsWeightThroughTheBoundaryContact) {
  const int N = 12;
  const double r = 0.1, w = 2.5e3, c = 4.0 * r;
  dem::Particles p;
  for (int k = 0; k < N; ++k) {
    p.x.push_back(0.0);
    p.z.push_back(r + 2.0 * r * k);
    p.radius.push_back(r);
    p.mass.push_back(w / 9.81);
  }
  std::vector<dem::ContactView> views;
  views.push_back({0, -1, 0.0, 0.0, N * w, 0.0, false}); // bottom disk on boundary 0 at (0, 0)
  for (int k = 0; k + 1 < N; ++k) // the upper disk (i) on the lower one (j): pushed up
    views.push_back({static_cast<std::uint32_t>(k + 1), k, 0.0,
                     p.z[static_cast<std::size_t>(k)] + r, (N - 1 - k) * w, 0.0, false});
  const auto dir = std::filesystem::temp_directory_path() / "demfem_cg_column";
  std::filesystem::create_directories(dir);
  dem::io::write_force_chains_vtp(dir / "chains.vtp", p, views);
  const auto contacts = compare::read_force_chains_vtp(dir / "chains.vtp");
  std::filesystem::remove_all(dir);
  ASSERT_EQ(contacts.size(), static_cast<std::size_t>(N));
  EXPECT_TRUE(contacts[0].boundary);
  EXPECT_FALSE(contacts[1].boundary);

  compare::CgParticles parts;
  parts.x = p.x;
  parts.z = p.z;
  parts.mass = p.mass;
  compare::Grid g;
  g.h = c / 40.0;
  g.x0 = -1.25 * c;
  g.z0 = -1.25 * c;
  g.nx = static_cast<int>(2.5 * c / g.h) + 1;
  g.nz = static_cast<int>((2.0 * r * N + 2.5 * c) / g.h) + 1;
  const auto total = [&](const std::vector<compare::CgContact>& cs) { // ∫∫ σ_zz dA
    const auto f = compare::coarse_grain(parts, cs, g, c);
    double s = 0.0;
    for (std::size_t n = 0; n < g.size(); ++n) s += f.szz[n] * g.h * g.h;
    return s;
  };
  const double virial = -w * r * N * N;
  EXPECT_NEAR(total(contacts), virial, 2e-3 * std::abs(virial));
  const std::vector<compare::CgContact> pairs_only(contacts.begin() + 1, contacts.end());
  EXPECT_GT(std::abs(total(pairs_only) - virial), 0.05 * std::abs(virial)); // the test can fail

  const auto f = compare::coarse_grain(parts, contacts, g, c);
  for (int k = 0; k < N; ++k) {
    const double zk = p.z[static_cast<std::size_t>(k)];
    if (zk - c < 0.0 || zk + c > p.z.back()) continue; // kernel clear of the column's ends
    const int row = static_cast<int>(std::lround((zk - g.z0) / g.h));
    double s = 0.0;
    for (int i = 0; i < g.nx; ++i) s += f.szz[g.at(i, row)] * g.h;
    EXPECT_NEAR(s, -(N - k - 0.5) * w, 5e-3 * N * w) << "section through disk " << k;
  }
}

// The share of the soil's area beyond the small-strain limit, by cell values (the continuum's cell
// arrays spread onto the cells' points), structure cells left out.
TEST(CoarseGrain, StrainRangeTellsTheSoilAreaBeyondSmallStrains) {
  compare::ContinuumSnapshot s;
  // three unit squares side by side: soil (ε_v 0.5), soil (ε_v −0.01, ε_p 0.02), structure (ε_v 9)
  for (int c = 0; c < 3; ++c) {
    const double x0 = c;
    const std::size_t b = s.x.size();
    s.x.insert(s.x.end(), {x0, x0 + 1, x0 + 1, x0});
    s.z.insert(s.z.end(), {0, 0, 1, 1});
    s.cells.push_back({b, b + 1, b + 2, b + 3});
    const double ev[3] = {0.5, -0.01, 9.0}, ep[3] = {0.0, 0.02, 9.0}, mat[3] = {0, 0, 1};
    for (int k = 0; k < 4; ++k) {
      s.data["volumetric_strain"].push_back(ev[c]);
      s.data["plastic_strain"].push_back(ep[c]);
      s.data["material"].push_back(mat[c]);
    }
  }
  const auto r = compare::continuum_strain_range(s, compare::kSmallStrainLimit);
  EXPECT_DOUBLE_EQ(r.area, 2.0);
  EXPECT_DOUBLE_EQ(r.area_beyond, 1.0);
  EXPECT_DOUBLE_EQ(r.share_beyond(), 0.5);
  EXPECT_DOUBLE_EQ(r.max_volumetric, 0.5);
  EXPECT_DOUBLE_EQ(r.vol_x, 0.5);
  EXPECT_DOUBLE_EQ(r.vol_z, 0.5);
  EXPECT_DOUBLE_EQ(r.max_plastic, 0.02);
  EXPECT_DOUBLE_EQ(r.plastic_x, 1.5);
  // within the limit everywhere: nothing beyond
  s.data["volumetric_strain"][0] = s.data["volumetric_strain"][1] = 0.05;
  s.data["volumetric_strain"][2] = s.data["volumetric_strain"][3] = 0.05;
  EXPECT_DOUBLE_EQ(compare::continuum_strain_range(s, compare::kSmallStrainLimit).area_beyond, 0.0);
}

// The DEM's surface settlement follows the particles that formed the surface at rest
// (matched surfaces: the continuum's top nodes are material too). Two bins of 1 m, particles of
// radius 0.05 m (one mean diameter 0.1 m): in each bin a top pair and a particle 0.3 m below
// (not surface). At the end the top particles of bin 0 are 0.01 m lower, those of bin 1 0.03 m,
// the deep ones 0.5 m (they must not count); the end snapshot lists the particles in another
// order (found by id), one top particle of bin 1 has left the scene, and one particle beyond x1
// is ignored. The top of the bed per bin would give 0.01 and 0.03 only by chance: here a deep
// particle of bin 1 is thrown to the top at the end, and the top of the bed there rises 0.2 m.
TEST(CoarseGrain, DemSurfaceSettlementFollowsTheSurfaceParticles) {
  compare::ParticleSnapshot rest, end;
  auto add = [](compare::ParticleSnapshot& s, std::uint32_t id, double x, double z) {
    s.id.push_back(id);
    s.x.push_back(x);
    s.z.push_back(z);
    s.radius.push_back(0.05);
    s.vx.push_back(0.0);
    s.vz.push_back(0.0);
  };
  add(rest, 0, 0.2, 1.00); // bin 0, top
  add(rest, 1, 0.6, 0.96); // bin 0, top (within one diameter)
  add(rest, 2, 0.4, 0.70); // bin 0, deep
  add(rest, 3, 1.2, 1.00); // bin 1, top
  add(rest, 4, 1.7, 0.95); // bin 1, top, leaves the scene
  add(rest, 5, 1.5, 0.70); // bin 1, deep
  add(rest, 6, 2.5, 2.00); // beyond x1
  add(end, 6, 2.5, 0.0);
  add(end, 5, 1.5, 1.20); // deep particle thrown to the top
  add(end, 3, 1.2, 0.97);
  add(end, 2, 0.4, 0.20);
  add(end, 1, 0.6, 0.95);
  add(end, 0, 0.2, 0.99);
  const auto s = compare::dem_surface_settlement(rest, end, 0.0, 2.0, 2);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_NEAR(s[0], 0.01, 1e-12);
  EXPECT_NEAR(s[1], 0.03, 1e-12);
  // wider bins: particle 6 now counts (bin 2, 2 m down); bin 3 has no particle
  const auto wide = compare::dem_surface_settlement(rest, end, 0.0, 4.0, 4);
  ASSERT_EQ(wide.size(), 4u);
  EXPECT_NEAR(wide[0], 0.01, 1e-12);
  EXPECT_NEAR(wide[2], 2.0, 1e-12);
  EXPECT_TRUE(std::isnan(wide[3]));
  // no particles at rest: every bin NaN
  for (const double v : compare::dem_surface_settlement({}, end, 0.0, 2.0, 2))
    EXPECT_TRUE(std::isnan(v));
}
