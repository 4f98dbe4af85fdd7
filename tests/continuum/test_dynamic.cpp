// Dynamic verification: first shear-beam frequency of a soil column, f1 = V_s/(4H).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include "fem.hpp"

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
  pb.soil.young = E;
  pb.soil.poisson = nu;
  pb.soil.plastic = false;
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
