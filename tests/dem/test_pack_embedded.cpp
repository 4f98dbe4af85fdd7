// Embedded structures in a packed bed (issue 9): a foundation inside the fill is carved out of a
// bed deposited without it, and one the run holds vertically fixed is lowered onto the bed until
// the bed carries its weight. Before this, the bed was deposited around the fixed foundation and
// the column under it settled away: no particle touched the foundation (foundation 2-A). A
// 300-disk bed in a 1.5 m box with a 0.4 m wide foundation 0.08 m below its surface (≈ 10 s).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdio>

#include "../scratch.hpp"

#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/scene/load.hpp"
#include "small_bed.hpp"

namespace fs = std::filesystem;
using namespace demfem;

namespace {

const std::string kScene = test::small_bed("embedded-footing", "", R"(
[[structure]]
name = "footing"
kind = "footing"
shape = "rectangle"
width = 0.4
height = 0.15
base = [0.75, 0.48]
density = 2400
dof_x = "fixed"
dof_z = "fixed"
dof_rotation = "free"
)");

fs::path fresh_dir(const std::string& name) {
  return demfem::test::scratch(name);
}

} // namespace

TEST(PackEmbedded, FoundationIsCarvedSeatedAndCarriedByTheBed) {
  const auto file = scene::parse_scene(kScene, "embedded.toml", demfem::app::vocabulary());
  const auto& s = file.base;
  const auto dir = fresh_dir("a");
  const auto r = dem::pack(s, dir);
  const auto& P = r.particles;
  const double rmax = 0.035;
  EXPECT_GT(r.carved, 0u);
  EXPECT_EQ(P.size() + r.carved, 300u);
  ASSERT_EQ(r.seat_dz.size(), 1u);
  // Lowered, by less than one largest diameter, until the bed carried it, then left to come to
  // rest on the bed under its weight (vertical DoF free): at the end of the packing the bed
  // carries W within 2 % (held where the lowering stopped, the bed relaxed under it to 0.77 W
  // under foundation 2-A).
  EXPECT_LE(r.seat_dz[0], 0.0);
  EXPECT_GT(r.seat_dz[0], -2.0 * rmax);
  EXPECT_NEAR(r.seat_load, 1.0, 0.02);
  // The footing is free to rotate in the run: it was seated free to rotate too.
  ASSERT_EQ(r.seat_rot.size(), 1u);
  EXPECT_LT(std::abs(r.seat_rot[0]), 0.05); // a small tilt, not a topple
  const auto st = scene::rotated(scene::shifted(s.structures[0], r.seat_dz[0]), r.seat_rot[0]);
  const double z0 = st.base_centre.z, x0 = st.base_centre.x - 0.2, x1 = st.base_centre.x + 0.2;
  // Particles touch the base (within 2 % of their radius): no hollow under it. Lowered until the
  // bed carries its weight, the footing rests on the highest few (measured: 1 here, with
  // 7 diameters across the base; 4 of ≈ 11 under foundation 2-A).
  int touching = 0;
  const double tilt = r.seat_rot[0];
  for (std::size_t i = 0; i < P.size(); ++i) {
    // gap to the (tilted) base line through the base centre
    const double zb = z0 + std::tan(tilt) * (P.x[i] - st.base_centre.x);
    if (P.x[i] < x0 || P.x[i] > x1 || P.z[i] > zb) continue;
    const double gap = (zb - P.z[i]) * std::cos(tilt) - P.radius[i];
    if (gap < 0.02 * P.radius[i]) ++touching;
    // and none is pushed into it by more than a loaded contact's overlap
    EXPECT_GT(gap, -0.05 * P.radius[i]) << i;
  }
  EXPECT_GE(touching, 1);
  // The run's engine with the seated footing: the bed pushes it up from the first step.
  dem::Engine e(dem::make_config(s));
  for (std::size_t i = 0; i < P.size(); ++i) e.add_particle(P.x[i], P.z[i], P.radius[i]);
  for (const auto& w : s.walls) e.add_wall(w);
  e.add_structure(st);
  e.load_contact_history(r.contact_history); // as dem::run: with the footing's shear springs
  e.run_steps(1);
  const double weight = e.structures()[0].mass * s.load.gravity;
  std::printf("seated footing: seat_dz %.4g m, seat_load %.5f, first-step soil Fz %.5f W\n",
              r.seat_dz[0], r.seat_load, e.structures()[0].soil_fz / weight);
  EXPECT_NEAR(e.structures()[0].soil_fz, weight, 0.02 * weight);
  // and in moment equilibrium about its pivot: the bed's moment balances that of the weight
  // (centroid off the pivot's vertical by the seat rotation), within 2 % of W × half-width
  // (measured: 1e-13). Seated with its rotation held, a footing carries the bed's unbalanced
  // moment into the run (foundation 2-A: −1.95e7 N·m, and it tipped 2.2e-3 rad in the first
  // second); without the face contacts' shear springs, 25 % of W × half-width here.
  {
    const auto& fs0 = e.structures()[0];
    // centroid's x offset from the pivot (cx_local: of the outline as placed, turned already)
    const double m_weight = -weight * fs0.cx_local; // moment of −W ẑ at that offset
    EXPECT_LT(std::abs(fs0.soil_moment + m_weight), 0.02 * weight * 0.2);
  }
  // Cached: the second call reads the same bed and seat back.
  const auto c = dem::pack_or_load(s, dir);
  EXPECT_TRUE(c.from_cache);
  EXPECT_EQ(c.particles.size(), P.size());
  ASSERT_EQ(c.seat_dz.size(), 1u);
  EXPECT_EQ(c.seat_dz[0], r.seat_dz[0]);
  fs::remove_all(dir);
}
