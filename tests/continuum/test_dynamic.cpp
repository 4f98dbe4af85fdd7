// Dynamic verification: first shear-beam frequency of a soil column, f1 = V_s/(4H).
#include <gtest/gtest.h>

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
}

TEST(ContinuumDynamic, ShearColumnFirstFrequency) {
  Problem pb;
  const double H = 10.0, E = 3.0e7, nu = 0.3, rho = 1700.0;
  pb.mesh.dx = {1.0};
  pb.mesh.dz = std::vector<double>(10, 1.0);
  pb.mesh.refinement = 1;
  pb.mesh.periodic_x = true;
  pb.fix_z_everywhere = true;
  pb.soil = demfem::test::elastic_soil(E, nu);
  pb.density = rho;
  pb.gravity = 0.0;
  Model m(pb);
  // start from the first mode shape, at rest
  m.set_displacement([&](Point p) { return Point{0.01 * std::sin(kPi * p.z / (2 * H)), 0.0}; });
  const double G = E / (2 * (1 + nu));
  const double f_exact = std::sqrt(G / rho) / (4 * H); // V_s/(4H), shear beam
  const double T = 1.0 / f_exact, dt = T / 200;
  std::vector<double> crossings;
  double prev = m.displacement({0.5, H}).x, t_prev = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  int newton = 0;
  for (int k = 1; k <= 700; ++k) {
    const StepStats st = m.dynamic_step(dt);
    ASSERT_TRUE(st.converged) << m.log();
    newton += st.newton_iterations;
    const double cur = m.displacement({0.5, H}).x;
    if (prev > 0 && cur <= 0) crossings.push_back(t_prev + dt * prev / (prev - cur));
    prev = cur;
    t_prev = m.time();
  }
  ASSERT_GE(crossings.size(), 3u);
  const double period = (crossings.back() - crossings.front()) / double(crossings.size() - 1);
  const double f = 1.0 / period;
  std::printf("shear column: dofs=%zu f=%.5f Hz (exact %.5f) rel.err=%.3e steps=700 newton=%d "
              "wall=%.2fs\n",
              m.n_dofs(), f, f_exact, (f - f_exact) / f_exact, newton,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  EXPECT_NEAR(f, f_exact, 0.02 * f_exact);
}

// Lysmer & Kuhlemeyer (1969) viscous base: a dashpot ρ c_s per unit area absorbs a normally
// incident plane shear wave exactly (reflection coefficient (ρc_s − C)/(ρc_s + C) = 0). A
// Gaussian shear pulse released at rest in a column (it splits into a down- and an up-going
// half; the upper half reflects at the free top) must leave through the absorbing base: after
// every part has had time to reach it, the energy left is < 10 % of the initial energy. With a
// fixed base (the control) the energy stays (Newmark's average acceleration conserves it).
TEST(ContinuumDynamic, LysmerBaseAbsorbsShearPulse) {
  const double H = 20.0, E = 3.0e7, nu = 0.3, rho = 1700.0;
  const double G = E / (2 * (1 + nu)), cs = std::sqrt(G / rho);
  double left[2] = {0, 0};
  for (int absorbing = 0; absorbing < 2; ++absorbing) {
    Problem pb;
    pb.mesh.dx = {1.0};
    pb.mesh.dz = std::vector<double>(static_cast<std::size_t>(H / 0.5), 0.5);
    pb.mesh.periodic_x = true;
    pb.fix_z_everywhere = true;
    pb.soil = demfem::test::elastic_soil(E, nu);
    pb.density = rho;
    pb.gravity = 0.0;
    pb.bottom = absorbing ? Bc::Free : Bc::Fixed;
    pb.absorbing = absorbing == 1;
    pb.absorbing_sides[0] = pb.absorbing_sides[1] = pb.absorbing_sides[3] = false;
    pb.absorbing_sides[2] = true;
    Model m(pb);
    m.set_displacement([&](Point p) {
      const double s = (p.z - 12.0) / 1.5;
      return Point{1e-3 * std::exp(-s * s), 0.0};
    });
    const double e0 = m.elastic_energy();
    // the up-going half travels 8 m up and 20 m down, plus ≈ 4 pulse widths: t = 40 m / c_s
    const double dt = 0.25 / cs, t_end = 40.0 / cs;
    while (m.time() < t_end) ASSERT_TRUE(m.dynamic_step(dt).converged) << m.log();
    left[absorbing] = m.elastic_energy() / e0;
  }
  std::printf(
      "shear pulse: energy left after %.0f m of travel: fixed base %.4f, Lysmer base %.4f\n", 40.0,
      left[0], left[1]);
  EXPECT_GT(left[0], 0.9);
  EXPECT_LT(left[1], 0.1);
}
