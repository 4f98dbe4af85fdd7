// Reduced forms of the paper's scenes: packing determinism and cache reuse, and the
// qualitative findings that survive a shorter run. Full-resolution runs carry the label `long`.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "../scratch.hpp"
#include <nlohmann/json.hpp>

#include "demfem/app/vocabulary.hpp"
#include "demfem/compare/figures.hpp"
#include "demfem/compare/plot.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/scene/load.hpp"

namespace fs = std::filesystem;
using namespace demfem;

namespace {

fs::path case_file(const std::string& name) {
  return fs::path(DEMFEM_SOURCE_DIR) / "cases" / name;
}

fs::path fresh_dir(const std::string& name) {
  return demfem::test::scratch_dir(name);
}

scene::Scene load(const std::string& file, const std::string& variant = "") {
  auto f = scene::load_scene_file(case_file(file), demfem::app::vocabulary());
  scene::Scene s = f.select(variant);
  s.soil.dem->packing.cache.clear(); // <out>/packing: tests never touch runs/
  return s;
}

bool long_enabled() {
  return std::getenv("DEMFEM_LONG") != nullptr;
}

} // namespace

TEST(Packing, RadiiAreDeterministicAndInRange) {
  scene::RadiusDistribution d;
  d.min = 0.04;
  d.max = 0.075;
  const auto a = dem::draw_radii(d, 1000, 7), b = dem::draw_radii(d, 1000, 7),
             c = dem::draw_radii(d, 1000, 8);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  double mean = 0.0;
  for (double r : a) {
    EXPECT_GE(r, 0.04);
    EXPECT_LT(r, 0.075);
    mean += r / 1000.0;
  }
  EXPECT_NEAR(mean, 0.0575, 0.002); // uniform mean (min + max)/2
}

TEST(Packing, PlacementHasNoOverlapAndStaysInTheFill) {
  auto s = load("retaining_wall.toml");
  s.soil.dem->count = 800;
  const auto p = dem::place_particles(s);
  ASSERT_EQ(p.size(), 800u);
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_GE(p.x[i] - p.radius[i], 0.0);
    EXPECT_LE(p.x[i] + p.radius[i], 8.0);
    EXPECT_GE(p.z[i] - p.radius[i], 0.0);
    for (std::size_t j = i + 1; j < p.size(); ++j)
      ASSERT_GE(std::hypot(p.x[i] - p.x[j], p.z[i] - p.z[j]), p.radius[i] + p.radius[j])
          << i << " " << j;
  }
}

TEST(Packing, DepositsReproduciblyAndReusesTheCache) {
  auto s = load("retaining_wall.toml");
  s.soil.dem->count = 400;
  const auto d1 = fresh_dir("pack1"), d2 = fresh_dir("pack2");
  const auto a = dem::pack_or_load(s, d1);
  EXPECT_FALSE(a.from_cache);
  EXPECT_TRUE(fs::exists(a.path));
  const auto b = dem::pack_or_load(s, d2); // another directory: deposits again
  EXPECT_FALSE(b.from_cache);
  EXPECT_EQ(a.particles.x, b.particles.x); // bit-identical
  EXPECT_EQ(a.particles.z, b.particles.z);
  const auto c = dem::pack_or_load(s, d1);
  EXPECT_TRUE(c.from_cache);
  EXPECT_EQ(a.particles.x, c.particles.x);
  // At rest, in the box, below where it was placed.
  EXPECT_LT(a.ke_ratio, s.soil.dem->packing.ke_ratio * 10);
  for (std::size_t i = 0; i < a.particles.size(); ++i) {
    EXPECT_GT(a.particles.z[i], 0.0);
    EXPECT_LT(a.particles.x[i], 8.0);
  }
  // A loading-only variant shares the packing; a different seed does not.
  auto v = s;
  v.load.shaking->acceleration.amplitude = 8.0;
  EXPECT_EQ(dem::packing_key(v), dem::packing_key(s));
  v.info.seed += 1;
  EXPECT_NE(dem::packing_key(v), dem::packing_key(s));
}

TEST(CaseFiles, AllPaperScenesLoad) {
  for (const char* f : {"slope_ontake.toml", "pile_penetration.toml", "foundation_rocking.toml",
                        "retaining_wall.toml"}) {
    EXPECT_NO_THROW((void)scene::load_scene_file(case_file(f), demfem::app::vocabulary())) << f;
  }
  const auto pile =
      scene::load_scene_file(case_file("pile_penetration.toml"), demfem::app::vocabulary());
  EXPECT_EQ(pile.variants.size(), 7u); // Table 4.1 rows + loose-case-1
  EXPECT_DOUBLE_EQ(pile.select("case-2").structure("pile")->width, 30.0);
  const auto rock =
      scene::load_scene_file(case_file("foundation_rocking.toml"), demfem::app::vocabulary());
  // Table 5.1 rows + 2-A-quick (the main job) + 4 loose + 4 with the loads × 240 (K_n scale) +
  // 2-A-unloaded (the control: no load, 2-A's packing)
  EXPECT_EQ(rock.variants.size(), 14u);
  {
    const auto u = rock.select("2-A-unloaded"), a = rock.select("2-A");
    EXPECT_EQ(u.structures.at(0).force_x(7.3), 0.0);
    EXPECT_NE(a.structures.at(0).force_x(7.3), 0.0);
    EXPECT_EQ(dem::packing_key(u), dem::packing_key(a));
  }
  // The loose variants change the packing only: random placement, porosity target
  // 0.184; the loading of the row they repeat is unchanged, and their packing is their own.
  for (const auto& [loose, dense] :
       {std::pair{"loose-2-A", "2-A"}, std::pair{"loose-1-B", "1-B"}}) {
    const auto l = rock.select(loose), d = rock.select(dense);
    ASSERT_TRUE(l.soil.dem && d.soil.dem) << loose;
    EXPECT_EQ(l.soil.dem->packing.placement, scene::Placement::Random) << loose;
    EXPECT_EQ(d.soil.dem->packing.placement, scene::Placement::Lattice) << dense;
    EXPECT_DOUBLE_EQ(l.soil.dem->packing.target_porosity.value_or(0.0), 0.184) << loose;
    EXPECT_DOUBLE_EQ(l.structures.at(0).force_x.omega, d.structures.at(0).force_x.omega) << loose;
    EXPECT_DOUBLE_EQ(l.structures.at(0).width, d.structures.at(0).width) << loose;
    EXPECT_NE(dem::packing_key(l), dem::packing_key(d)) << loose;
  }
  // The kn-scaled variants change the load amplitude only, × K_n / 1.0e6 (the
  // paper's K_n), and share the row's packing.
  const double kn_scale =
      scene::value_of(*rock.base.soil.dem->model("contact"), "kn").value() / 1.0e6;
  for (const auto& [scaled, row] :
       {std::pair{"kn-scaled-1-A", "1-A"}, std::pair{"kn-scaled-1-B", "1-B"},
        std::pair{"kn-scaled-2-A", "2-A"}, std::pair{"kn-scaled-2-B", "2-B"}}) {
    const auto k = rock.select(scaled), r = rock.select(row);
    EXPECT_DOUBLE_EQ(k.structures.at(0).force_x.amplitude,
                     kn_scale * r.structures.at(0).force_x.amplitude)
        << scaled;
    EXPECT_DOUBLE_EQ(k.structures.at(0).force_x.omega, r.structures.at(0).force_x.omega) << scaled;
    EXPECT_EQ(dem::packing_key(k), dem::packing_key(r)) << scaled;
  }
  const auto pl = pile.select("loose-case-1"), pd = pile.select("case-1");
  EXPECT_EQ(pl.soil.dem->packing.placement, scene::Placement::Random);
  EXPECT_DOUBLE_EQ(pl.soil.dem->packing.target_porosity.value_or(0.0), 0.184);
  EXPECT_NE(dem::packing_key(pl), dem::packing_key(pd));
}

TEST(LoopArea, UnitSquare) {
  EXPECT_DOUBLE_EQ(compare::loop_area({0, 1, 1, 0}, {0, 0, 1, 1}), 1.0);
}

// Pile case 1, full bed, 6 s instead of 20 s: the pile goes down, and deeper as the load grows.
TEST(PaperPile, PenetrationDeepensWithTheLoad) {
  // Reduced: 1,000 disks with radii × √3.4 fill the same 160 m × ~100 m bed (same δ/r at the base
  // with the same K_n; Δt grows by √3.4), ~6× cheaper than the 3,400-disk case; 6 s of load A.
  auto s = load("pile_penetration.toml", "case-1");
  s.soil.dem->count = 1000;
  s.soil.dem->radius.min *= std::sqrt(3.4);
  s.soil.dem->radius.max *= std::sqrt(3.4);
  s.info.duration = 6.0;
  s.output.vtk = false;
  const auto dir = fresh_dir("pile");
  dem::RunOptions o;
  o.out_dir = dir;
  const auto r = dem::run(s, o);
  ASSERT_TRUE(r.ok) << r.message;
  const auto t = compare::read_csv(dir / "dem" / "structures.csv");
  const auto time = t.column("time"), settle = t.column("pile.settlement");
  ASSERT_GT(settle.size(), 10u);
  double mid = 0.0;
  for (std::size_t i = 0; i < time.size(); ++i)
    if (time[i] <= 3.0) mid = settle[i];
  EXPECT_GT(settle.back(), mid);  // deeper at 6 s than at 3 s
  EXPECT_GT(settle.back(), 0.05); // it penetrated (downward positive)
}

// Ontake, 12 s: with the basal friction gone the mass runs down at tens of m/s.
TEST(PaperOntake, DebrisAccelerates) {
  auto s = load("slope_ontake.toml");
  s.info.duration = 12.0;
  const auto dir = fresh_dir("ontake");
  dem::RunOptions o;
  o.out_dir = dir;
  const auto r = dem::run(s, o);
  ASSERT_TRUE(r.ok) << r.message;
  const auto f = compare::write_run_figures(s, dir, r.wall_seconds, r.steps);
  std::ifstream in(f.summary);
  const auto j = nlohmann::json::parse(in);
  ASSERT_TRUE(j.contains("snapshot_peak_speed_m_s"));
  EXPECT_GT(j["snapshot_peak_speed_m_s"].get<double>(), 10.0);
}

// Full-resolution runs (label `long`; run with DEMFEM_LONG=1).
TEST(PaperLong, PileCase1DeeperThanCases2And3) {
  if (!long_enabled()) GTEST_SKIP() << "set DEMFEM_LONG=1";
  double depth[4] = {0, 0, 0, 0};
  for (int c = 1; c <= 3; ++c) {
    auto s = load("pile_penetration.toml", "case-" + std::to_string(c));
    s.output.vtk = false;
    const auto dir = fresh_dir("pile_long" + std::to_string(c));
    dem::RunOptions o;
    o.out_dir = dir;
    ASSERT_TRUE(dem::run(s, o).ok);
    depth[c] = compare::read_csv(dir / "dem" / "structures.csv").column("pile.settlement").back();
  }
  EXPECT_GT(depth[1], depth[2]);
  EXPECT_GT(depth[1], depth[3]);
}
