// Packing density as a scene input (issue 14): [soil.dem.packing] target = { porosity = n } is
// reached by raised-friction deposition from a random placement, and the packing is
// deterministic. A 300-disk bed in a 1.5 m box (≈ 10 s). The porosity reached depends weakly and
// not monotonically on the deposition friction (0.200–0.209 at × 1…4, measured), so the test asks
// for a target in that band and checks that what is reported as met is met.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "../scratch.hpp"

#include "demfem/app/vocabulary.hpp"
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
      bed("placement = \"random\"\ntarget = { porosity = 0.21, tolerance = 0.01 }"), "bed.toml",
      demfem::app::vocabulary());
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
      bed("placement = \"random\"\ntarget = { porosity = 0.40, tolerance = 0.005 }"), "bed.toml",
      demfem::app::vocabulary());
  const auto r = dem::pack(file.base, fresh_dir("c"));
  EXPECT_FALSE(r.target_met);
  EXPECT_GT(std::abs(r.measure.porosity - 0.40), 0.005);
  // And it stops raising the friction once a doubling no longer brings the porosity nearer
  // (0.200–0.209 at × 1…4 against 0.40): not all five doublings up to × 16.
  EXPECT_LT(r.trials, 5);
}

TEST(PackTarget, PlacementsGiveDifferentBedsAndKeys) {
  const auto lat =
      scene::parse_scene(bed("placement = \"lattice\""), "bed.toml", demfem::app::vocabulary());
  const auto ran =
      scene::parse_scene(bed("placement = \"random\""), "bed.toml", demfem::app::vocabulary());
  const auto l = dem::pack(lat.base, fresh_dir("l"));
  const auto r = dem::pack(ran.base, fresh_dir("r"));
  EXPECT_GT(l.measure.porosity, 0.1);
  EXPECT_LT(l.measure.porosity, 0.3);
  EXPECT_GT(r.measure.porosity, 0.1);
  EXPECT_LT(r.measure.porosity, 0.3);
  EXPECT_NE(l.measure.porosity, r.measure.porosity);
  EXPECT_NE(dem::packing_key(lat.base), dem::packing_key(ran.base));
}

// The deposition stops when the bed is at rest (every particle slower than 1 % of the damped fall
// speed g/C, and KE below ke_ratio × the released potential energy), not only after t_min, the
// time the highest placed particle would take to fall to the bottom of the fill at g/C: that
// bound ignores that it lands on the bed's top. Here t_min ≈ (top of the placement) · C/g with
// C = 2ζ√(K_n/m̄) (pack.cpp); before the change the deposition always ran to t_min (or to
// max_time, unconverged). And the bed it stops with is the bed a longer deposition gives:
// with ke_ratio 1e-30 (KE never that small before max_time) the same porosity and surface.
// (Here, measured: t_min ≈ 4.0 s, at rest at 2.75 s; the longer deposition gives porosity 0.19660
// against 0.196595 and the same surface to 2e-6 m.)
TEST(PackRest, StopsWhenTheBedIsAtRestNotAtTheFallBound) {
  const auto rest =
      scene::parse_scene(bed("ke_ratio = 1.0e-4\n"), "bed.toml", demfem::app::vocabulary()).base;
  const auto wait =
      scene::parse_scene(bed("ke_ratio = 1.0e-30\n"), "bed.toml", demfem::app::vocabulary()).base;
  const double max_time = 10.0; // small_bed.hpp
  const auto placed = dem::place_particles(rest);
  double top = 0.0, m_mean = 0.0;
  for (std::size_t i = 0; i < placed.size(); ++i) {
    top = std::max(top, placed.z[i]);
    m_mean += 2650.0 * M_PI * placed.radius[i] * placed.radius[i] / placed.size(); // ρπr²t
  }
  const double C = 2.0 * 0.05 * std::sqrt(1.0e6 / m_mean); // packing.damping = 0.05, K_n = 1e6
  const double t_min = top * C / 9.81;
  const auto a = dem::pack(rest, fresh_dir("rest"));
  EXPECT_TRUE(a.converged);
  EXPECT_LT(a.deposition_time, 0.8 * std::min(t_min, max_time)) << "t_min " << t_min;
  EXPECT_LT(a.ke_ratio, 1.0e-4);
  const auto b = dem::pack(wait, fresh_dir("wait"));
  EXPECT_GE(b.deposition_time, max_time); // waited to the end
  EXPECT_NEAR(a.measure.porosity, b.measure.porosity, 1e-3);
  EXPECT_NEAR(a.surface_max, b.surface_max, 0.1 * 0.02); // a tenth of r_min
}

TEST(PackTarget, DenserTargetTriesHalfTheFrictionFirst) {
  auto pack_to = [](const char* porosity, const char* dir) {
    const std::string packing = std::string("placement = \"random\"\ntarget = { porosity = ") +
                                porosity + ", tolerance = 0.003 }";
    return dem::pack(scene::parse_scene(bed(packing), "bed.toml", demfem::app::vocabulary()).base,
                     fresh_dir(dir));
  };
  // This bed packs to 0.2043 at × 1 and 0.1793 at × ½: a target of 0.18 is met by the second
  // deposition (a frictionless one first, as before, made it the third).
  const auto met = pack_to("0.18", "d");
  EXPECT_TRUE(met.target_met);
  EXPECT_EQ(met.trials, 2);
  EXPECT_EQ(met.friction_scale, 0.5);
  // Denser than any deposition can make it: × 1, ½, then frictionless, reported not met.
  const auto dense = pack_to("0.05", "e");
  EXPECT_FALSE(dense.target_met);
  EXPECT_EQ(dense.trials, 3);
  EXPECT_EQ(dense.friction_scale, 0.0); // the densest bed, nearest to the target
}

// overlapping_pairs (the grid search behind the coordination number and the final figures' chains)
// gives what testing every pair gives, in the same order: random disks of two sizes, some
// removed, one pair exactly touching (not overlapping) and one particle far away.
TEST(OverlappingPairs, SameAsEveryPairTested) {
  dem::Particles p;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 3.0), r(0.02, 0.08);
  auto add = [&](double x, double z, double rad, std::uint8_t flags) {
    p.x.push_back(x);
    p.z.push_back(z);
    p.radius.push_back(rad);
    p.flags.push_back(flags);
  };
  for (int k = 0; k < 2000; ++k)
    add(u(rng), u(rng), r(rng), k % 97 == 0 ? std::uint8_t{dem::kFlagRemoved} : std::uint8_t{0});
  add(10.0, 10.0, 0.05, 0); // exactly touching: |x_i − x_j| = r_i + r_j, not a contact
  add(10.125, 10.0, 0.075, 0);
  add(1.0e6, -3.0e5, 0.05, 0); // far away: no empty cells in between
  std::vector<std::pair<std::uint32_t, std::uint32_t>> all;
  for (std::uint32_t i = 0; i < p.x.size(); ++i)
    for (std::uint32_t j = i + 1; j < p.x.size(); ++j) {
      if ((p.flags[i] | p.flags[j]) & dem::kFlagRemoved) continue;
      if (std::hypot(p.x[i] - p.x[j], p.z[i] - p.z[j]) < p.radius[i] + p.radius[j])
        all.emplace_back(i, j);
    }
  const auto got = dem::overlapping_pairs(p);
  EXPECT_GT(all.size(), 500u); // a dense enough set to mean something
  EXPECT_EQ(got, all);
}
