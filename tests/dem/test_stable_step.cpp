// The DEM's stable time step (dem/stable_step.hpp): closed forms of the pair
// modes, the coordination margin against the eigenvalues of linear spring networks (Eigen), and
// the engine's refusal.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Dense>

#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/scene/load.hpp"

using namespace demfem;
using namespace demfem::dem;

namespace {

// Largest ω² of M⁻¹K for disks of mass m, inertia I, radius r joined by normal (k_n) and shear
// (k_s, with rotation) springs; a bond with j < 0 ties i to a fixed wall. Unit normal (ex, ez).
struct Bond {
  int i, j;
  double ex, ez;
};
double omega2_max(int n, double m, double I, double r, double kn, double ks,
                  const std::vector<Bond>& bonds) {
  const int N = 3 * n;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(N, N);
  for (const auto& b : bonds) {
    const double tx = -b.ez, tz = b.ex;
    Eigen::VectorXd bn = Eigen::VectorXd::Zero(N), bt = Eigen::VectorXd::Zero(N);
    bn[3 * b.i] -= b.ex;
    bn[3 * b.i + 1] -= b.ez;
    bt[3 * b.i] -= tx;
    bt[3 * b.i + 1] -= tz;
    bt[3 * b.i + 2] -= r; // s = (u_j − u_i)·t − r θ_i − r θ_j (contact_laws.hpp)
    if (b.j >= 0) {
      bn[3 * b.j] += b.ex;
      bn[3 * b.j + 1] += b.ez;
      bt[3 * b.j] += tx;
      bt[3 * b.j + 1] += tz;
      bt[3 * b.j + 2] -= r;
    }
    K += kn * bn * bn.transpose() + ks * bt * bt.transpose();
  }
  Eigen::VectorXd s(N);
  for (int i = 0; i < n; ++i) {
    s[3 * i] = s[3 * i + 1] = 1.0 / std::sqrt(m);
    s[3 * i + 2] = 1.0 / std::sqrt(I);
  }
  const Eigen::MatrixXd A = s.asDiagonal() * K * s.asDiagonal();
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A).eigenvalues().maxCoeff();
}

// Periodic triangular lattice (coordination 6), L × L.
std::vector<Bond> triangular(int L) {
  std::vector<Bond> b;
  auto id = [L](int a, int c) { return ((a % L + L) % L) + L * ((c % L + L) % L); };
  const double h = std::sqrt(3.0) / 2.0;
  for (int a = 0; a < L; ++a)
    for (int c = 0; c < L; ++c) {
      b.push_back({id(a, c), id(a + 1, c), 1.0, 0.0});
      b.push_back({id(a, c), id(a, c + 1), 0.5, h});
      b.push_back({id(a, c), id(a - 1, c + 1), -0.5, h});
    }
  return b;
}

StepParams params(double kn, double ks, double inertia_factor) {
  StepParams p;
  p.kn = kn;
  p.ks = ks;
  p.m_min = 1.0;
  p.r_min = 1.0;
  p.inertia_factor = inertia_factor;
  return p;
}

} // namespace

// Pair modes: equal disks ω² = 2k_n/m (normal, k_n/m*) and 6k_s/m (shear–rotation, I = ½mr²);
// spheres 7k_s/m (I = (2/5)mr²). The eigenvalues of one pair agree to 1e-12.
TEST(StableStep, PairModesMatchTheirClosedForms) {
  for (const double inertia : {0.5, 0.4})
    for (const double ks : {0.0, 0.3, 1.0}) {
      const auto b = critical_step(params(1.0, ks, inertia));
      const double expect = std::max(2.0, 2.0 * (1.0 + 1.0 / inertia) * ks);
      EXPECT_NEAR(b.omega_pair * b.omega_pair, expect, 1e-12);
      EXPECT_NEAR(omega2_max(2, 1.0, inertia, 1.0, 1.0, ks, {{0, 1, 1.0, 0.0}}), expect, 1e-12);
    }
  // For k_s = k_n the pair's shear–rotation limit 2/ω_pair = 2√(m/6k) is
  // 0.41× a lone spring's 2√(m/k); with the coordination margin (C = 4) Δt = √(m/6k).
  const auto b = critical_step(params(1.0, 1.0, 0.5));
  EXPECT_NEAR((2.0 / b.omega_pair) / 2.0, 1.0 / std::sqrt(6.0), 1e-12);
  EXPECT_NEAR(b.dt, 1.0 / std::sqrt(6.0), 1e-12);
  EXPECT_TRUE(b.shear_mode);
}

// Coordination margin: the triangular lattice (densest equal-disk packing) and a 20-disk column
// on a floor stay below C·ω_pair² for k_s/k_n from 0 to 2, disks and spheres; the bound is tight
// (equal within 1e-9) for the lattice's rotation mode when k_s ≥ k_n/2 (disks).
TEST(StableStep, CoordinationMarginCoversTheTriangularLattice) {
  for (const double inertia : {0.5, 0.4})
    for (const double ks : {0.0, 0.1, 0.3, 0.5, 1.0, 2.0}) {
      const auto b = critical_step(params(1.0, ks, inertia));
      const double bound = b.omega_max * b.omega_max;
      const double hex = omega2_max(100, 1.0, inertia, 1.0, 1.0, ks, triangular(10));
      std::vector<Bond> col{{0, -1, 0.0, -1.0}};
      for (int k = 0; k < 19; ++k) col.push_back({k, k + 1, 0.0, 1.0});
      const double column = omega2_max(20, 1.0, inertia, 1.0, 1.0, ks, col);
      std::printf("I/mr² %.1f k_s/k_n %.1f: lattice ω² %.4f, column %.4f, bound %.4f\n", inertia,
                  ks, hex, column, bound);
      EXPECT_LE(hex, bound * (1 + 1e-12));
      EXPECT_LE(column, bound * (1 + 1e-12));
      if (inertia == 0.5 && ks >= 0.5) {
        EXPECT_NEAR(hex, bound, 1e-9 * bound);
      }
    }
}

// Dashpots lower the limit by √(1 + ξ²) − ξ (Belytschko et al. 2000, eq. 6.3.36).
TEST(StableStep, DampingLowersTheLimit) {
  EngineConfig c; // the laws' own step data (dem/contact/), through step_params
  c.law = contact::make_law("cundall-rebound", {{"kn", 1.0e6}, {"ks", 3.0e5}});
  const double undamped = critical_step(step_params(c, 1.0, 1.0)).dt;
  c.law =
      contact::make_law("linear-restitution", {{"kn", 1.0e6}, {"ks", 3.0e5}, {"restitution", 0.5}});
  const double xi = contact::Restitution::damping_ratio(0.5); // ζ(e) of the clamped dashpot
  EXPECT_NEAR(critical_step(step_params(c, 1.0, 1.0)).dt, undamped * (std::sqrt(1 + xi * xi) - xi),
              1e-15);
  c.law = contact::make_law(
      "cundall-dashpot", // ξ_n = 0.3 at m* = m/2
      {{"kn", 1.0e6}, {"ks", 3.0e5}, {"eta_n", 2.0 * 0.3 * std::sqrt(0.5 * 1.0e6)}});
  EXPECT_NEAR(critical_step(step_params(c, 1.0, 1.0)).dt, undamped * (std::sqrt(1.09) - 0.3),
              1e-15);
}

// The engine refuses a step above the bound and names it; the scene-level bound (what `check`
// uses) equals the engine's for the same smallest particle.
TEST(StableStep, EngineAndSceneAgree) {
  const auto file = scene::parse_scene(R"(
[scene]
name = "pair"
duration = 0.1
[domain]
polygon = [[-1, -1], [1, -1], [1, 1], [-1, 1]]
[soil.dem]
count = 2
radius = { equal = 0.05 }
kn = 1.0e6
ks = 1.0e6
particles = [[-0.06, 0.0, 0.05, 0.0, 0.0, 0.0], [0.06, 0.0, 0.05, 0.0, 0.0, 0.0]]
)",
                                       "pair.toml", demfem::app::vocabulary());
  const auto sb = scene_critical_step(file.base);
  ASSERT_TRUE(sb);
  Engine e(make_config(file.base));
  for (const auto& q : file.base.soil.dem->particles) e.add_particle(q[0], q[1], q[2]);
  EXPECT_DOUBLE_EQ(e.stable_dt(), sb->dt);
  const double m = 2650.0 * std::numbers::pi * 0.05 * 0.05;
  EXPECT_NEAR(sb->dt, std::sqrt(m / 6.0e6), 1e-15);   // shear–rotation mode, k_s = k_n
  EXPECT_THROW(e.set_dt(1.01 * sb->dt), StepRefused); // the engine knows no scene
  EXPECT_NO_THROW(e.set_dt(0.99 * sb->dt));
  try { // a Δt from a scene: a located scene error at soil.dem.dt, with the limit
    set_scene_dt(e, 1.01 * sb->dt);
    ADD_FAILURE() << "no SceneError";
  } catch (const scene::SceneError& err) {
    ASSERT_EQ(err.diagnostics().size(), 1u);
    EXPECT_EQ(err.diagnostics()[0].key, "soil.dem.dt");
    EXPECT_NE(err.diagnostics()[0].message.find("stable"), std::string::npos)
        << err.diagnostics()[0].message;
  }
}
