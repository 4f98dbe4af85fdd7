// Packing density as a scene input (issue 14): [soil.dem.packing] target = { porosity = n } is
// reached by raised-friction deposition from a random placement, and the packing is
// deterministic. A 300-disk bed in a 1.5 m box (≈ 10 s). The porosity reached depends weakly and
// not monotonically on the deposition friction (0.200–0.209 at × 1…4, measured), so the test asks
// for a target in that band and checks that what is reported as met is met.
#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "../scratch.hpp"

#include "demfem/dem/pack.hpp"
#include "demfem/scene/load.hpp"
#include "small_bed.hpp"

namespace fs = std::filesystem;
using namespace demfem;

namespace {

std::string bed(const std::string& packing) {
  return test::small_bed("small-bed", packing);
}

fs::path fresh_dir(const std::string& name) {
  return demfem::test::scratch(name);
}

} // namespace

TEST(PackTarget, PorosityTargetMetAndDeterministic) {
  const auto file = scene::parse_scene(
      bed("placement = \"random\"\ntarget = { porosity = 0.21, tolerance = 0.01 }"), "bed.toml");
  const auto& s = file.base;
  const auto a = dem::pack(s, fresh_dir("a"));
  const auto b = dem::pack(s, fresh_dir("b"));
  EXPECT_TRUE(a.target_met);
  EXPECT_NEAR(a.measure.porosity, 0.21, 0.01);
  EXPECT_GE(a.trials, 1);
  // Deterministic: the same scene packs to the same bed, bit for bit.
  ASSERT_EQ(a.particles.size(), b.particles.size());
  for (std::size_t i = 0; i < a.particles.size(); ++i) {
    ASSERT_EQ(a.particles.x[i], b.particles.x[i]) << i;
    ASSERT_EQ(a.particles.z[i], b.particles.z[i]) << i;
  }
  EXPECT_EQ(a.measure.porosity, b.measure.porosity);
  EXPECT_EQ(a.friction_scale, b.friction_scale);
}

TEST(PackTarget, UnreachableTargetIsReportedNotMet) {
  // 0.40 is far looser than any stable bed of these disks: the packing says so.
  const auto file = scene::parse_scene(
      bed("placement = \"random\"\ntarget = { porosity = 0.40, tolerance = 0.005 }"), "bed.toml");
  const auto r = dem::pack(file.base, fresh_dir("c"));
  EXPECT_FALSE(r.target_met);
  EXPECT_GT(std::abs(r.measure.porosity - 0.40), 0.005);
}

TEST(PackTarget, PlacementsGiveDifferentBedsAndKeys) {
  const auto lat = scene::parse_scene(bed("placement = \"lattice\""), "bed.toml");
  const auto ran = scene::parse_scene(bed("placement = \"random\""), "bed.toml");
  const auto l = dem::pack(lat.base, fresh_dir("l"));
  const auto r = dem::pack(ran.base, fresh_dir("r"));
  EXPECT_GT(l.measure.porosity, 0.1);
  EXPECT_LT(l.measure.porosity, 0.3);
  EXPECT_GT(r.measure.porosity, 0.1);
  EXPECT_LT(r.measure.porosity, 0.3);
  EXPECT_NE(l.measure.porosity, r.measure.porosity);
  EXPECT_NE(dem::packing_key(lat.base), dem::packing_key(ran.base));
}
