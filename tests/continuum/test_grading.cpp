// Graded coarse grids (continuum.mesh_size_near, mesh_grading; continuum/run/mesh_grading.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <set>

#include "demfem/app/vocabulary.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/resources.hpp"
#include "mesh_grading.hpp"

using demfem::continuum::graded_steps_through;

// The foundation 2-A geometry along x: box 0–160 m, foundation 65–95 m, coarse size 28 m.
TEST(MeshGrading, FineAtTheFocusGrowingByAtMostTheRatioAndThroughEveryBreak) {
  const double h0 = 28.0, hn = 3.0, g = 1.25;
  const auto d = graded_steps_through({0.0, 65.0, 95.0, 160.0}, h0, hn, g, 65.0, 95.0);
  EXPECT_NEAR(std::accumulate(d.begin(), d.end(), 0.0), 160.0, 1e-9);
  // every break is a node
  std::vector<double> nodes{0.0};
  for (double s : d) nodes.push_back(nodes.back() + s);
  for (double b : {65.0, 95.0})
    EXPECT_TRUE(std::any_of(nodes.begin(), nodes.end(), [&](double x) {
      return std::abs(x - b) < 1e-9;
    })) << b;
  // across the focus: 30 m / 3 m = 10 equal cells
  int inside = 0;
  for (std::size_t k = 0; k + 1 < nodes.size(); ++k)
    if (nodes[k] >= 65.0 - 1e-9 && nodes[k + 1] <= 95.0 + 1e-9) {
      ++inside;
      EXPECT_NEAR(nodes[k + 1] - nodes[k], 3.0, 1e-6);
    }
  EXPECT_EQ(inside, 10);
  // neighbours differ by at most the ratio (+ the rounding of ⌈∫dx/h⌉), none above h0
  for (std::size_t k = 0; k + 1 < d.size(); ++k) {
    EXPECT_LE(std::max(d[k], d[k + 1]) / std::min(d[k], d[k + 1]), g * 1.15) << k;
    EXPECT_LE(d[k], h0 + 1e-9);
  }
  // fewer cells than a uniform 3 m grid (54), more than the uniform 28 m one (7)
  EXPECT_LT(d.size(), 30u);
  EXPECT_GT(d.size(), 7u);
}

TEST(MeshGrading, RatioOneIsUniformAtTheNearSize) {
  const auto d = graded_steps_through({0.0, 10.0}, 5.0, 1.0, 1.0, 4.0, 6.0);
  ASSERT_EQ(d.size(), 10u);
  for (double s : d) EXPECT_NEAR(s, 1.0, 1e-9);
}

// The scene check's memory estimate counts the coarse grid without the continuum
// (scene/src/resources.cpp): the same columns and rows as graded_steps_through gives for the
// foundation scene's graded mesh (breaks at the domain's and the foundation's corners, h0 =
// min(W, H)/4, cells of mesh_size_near at the foundation), and as the uniform grid otherwise.
TEST(MeshGrading, SceneEstimateCountsTheSameCoarseGrid) {
  const auto f = demfem::scene::load_scene_file(DEMFEM_SOURCE_DIR "/cases/foundation_rocking.toml",
                                                demfem::app::vocabulary());
  const auto& s = f.base;
  ASSERT_GT(s.continuum.mesh_size_near, 0.0);
  std::set<double> xs, zs;
  double bx0 = 1e300, bx1 = -1e300, bz0 = 1e300, bz1 = -1e300;
  for (const auto& p : s.domain) {
    xs.insert(p.x);
    zs.insert(p.z);
  }
  for (const auto& st : s.structures)
    for (const auto& p : st.outline) {
      xs.insert(p.x);
      zs.insert(p.z);
      bx0 = std::min(bx0, p.x);
      bx1 = std::max(bx1, p.x);
      bz0 = std::min(bz0, p.z);
      bz1 = std::max(bz1, p.z);
    }
  const double h0 = std::min(*xs.rbegin() - *xs.begin(), *zs.rbegin() - *zs.begin()) / 4.0;
  const double hn = std::min(s.continuum.mesh_size_near, h0);
  const auto dx = graded_steps_through(xs, h0, hn, s.continuum.mesh_grading, bx0, bx1);
  const auto dz = graded_steps_through(zs, h0, hn, s.continuum.mesh_grading, bz0, bz1);
  const auto e = demfem::scene::estimate_continuum_mesh(s);
  EXPECT_EQ(e.columns, dx.size());
  EXPECT_EQ(e.rows, dz.size());
  // meshed: the cells whose centre is in the soil or the foundation (it stands above the box)
  EXPECT_GT(e.coarse_cells, 0.5 * static_cast<double>(dx.size() * dz.size()));
  EXPECT_LT(e.coarse_cells, static_cast<double>(dx.size() * dz.size()));
  EXPECT_GT(dx.size(), 8u); // graded: finer than the uniform 4 × … grid
}
