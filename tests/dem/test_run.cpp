// End-to-end: dem::run on the verification scenes (explicit particles), events and refusals.
#include <gtest/gtest.h>

#include "../scratch.hpp"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/scene/load.hpp"

using namespace demfem;

namespace {
std::filesystem::path scratch(const std::string& name) {
  return demfem::test::scratch(name);
}
std::string last_line(const std::filesystem::path& f) {
  std::ifstream in(f);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}
} // namespace

// The head-on collision scene runs and writes its energy budget; the "fast" variant rebounds
// with K = 0.1, dissipating ½ m* v² (1 − K²) = ½·10.406·1.6²·0.99 = 13.19 J (within 2 %).
TEST(DemRun, HeadOnCollisionScene) {
  const auto file = scene::load_scene_file(
      DEMFEM_SOURCE_DIR "/cases/verification/head_on_collision.toml", demfem::app::vocabulary());
  dem::RunOptions o;
  o.out_dir = scratch("head_on");
  const auto s = dem::run(file.select("fast"), o);
  ASSERT_TRUE(s.ok) << s.message;
  EXPECT_EQ(s.particles, 2u);
  const auto row = last_line(o.out_dir / "dem" / "energy.csv");
  // columns: time, kinetic, rotational, potential, spring_n, spring_s, friction, damping, rebound
  std::vector<double> v;
  std::size_t pos = 0;
  while (pos <= row.size()) {
    const auto next = row.find(',', pos);
    v.push_back(std::stod(row.substr(pos, next - pos)));
    if (next == std::string::npos) break;
    pos = next + 1;
  }
  ASSERT_GE(v.size(), 9u);
  const double m_star = 0.5 * 2650 * 3.14159265358979 * 0.05 * 0.05;
  const double expected = 0.5 * m_star * 1.6 * 1.6 * (1 - 0.01);
  EXPECT_NEAR(v[8], expected, 0.02 * expected);
  // The end-of-run energy budget is written next to the CSV, with its rebound entry and closure.
  std::ifstream js(o.out_dir / "dem" / "energy_budget.json");
  ASSERT_TRUE(js.good());
  const std::string text((std::istreambuf_iterator<char>(js)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"rebound\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"closure_error\""), std::string::npos) << text;
}

// Settled box scene: the footing ends carried by the soil (force_z = its weight within 1 %).
TEST(DemRun, SettleBoxSceneCarriesFooting) {
  const auto file = scene::load_scene_file(DEMFEM_SOURCE_DIR "/cases/verification/settle_box.toml",
                                           demfem::app::vocabulary());
  dem::RunOptions o;
  o.out_dir = scratch("settle");
  const auto s = dem::run(file.base, o);
  ASSERT_TRUE(s.ok) << s.message;
  const auto row = last_line(o.out_dir / "dem" / "structures.csv");
  std::vector<double> v;
  std::size_t pos = 0;
  while (true) {
    const auto next = row.find(',', pos);
    v.push_back(std::stod(row.substr(pos, next - pos)));
    if (next == std::string::npos) break;
    pos = next + 1;
  }
  const double weight = 0.4 * 0.1 * 2400 * 9.81;
  ASSERT_GE(v.size(), 6u);
  EXPECT_NEAR(v[5], weight, 0.01 * weight); // footing.force_z [N]
}

// A scene time step above the stable limit is refused before anything runs.
TEST(DemRun, UnstableSceneStepIsRefused) {
  auto file = scene::load_scene_file(DEMFEM_SOURCE_DIR "/cases/verification/head_on_collision.toml",
                                     demfem::app::vocabulary());
  auto sc = file.base;
  sc.soil.dem->dt = 0.1;
  dem::RunOptions o;
  o.out_dir = scratch("refused");
  EXPECT_THROW((void)dem::run(sc, o), scene::SceneError);
}

// Events: opening a wall lets the particle resting on it fall; set-friction gives the particles
// in a region a new material.
TEST(DemEvents, OpenWallAndSetFriction) {
  dem::EngineConfig c;
  c.gravity = 9.81;
  dem::Engine e(c);
  e.add_wall({{-1, 0}, {1, 0}}, "floor");
  e.add_particle(0, 0.05, 0.05);
  e.add_particle(0.5, 0.05, 0.05);
  e.set_dt(e.auto_dt());
  while (e.time() < 0.2) e.step(); // settle on the floor
  const double z_before = e.particles().z[0];
  EXPECT_NEAR(z_before, 0.05, 0.01);
  EXPECT_EQ(e.set_friction({{-0.2, -1}, {0.2, -1}, {0.2, 1}, {-0.2, 1}}, 0.1, 0.05), 1u);
  EXPECT_EQ(e.materials().size(), 2u);
  e.open_wall("floor");
  while (e.time() < 0.4) e.step(); // free fall for 0.2 s: ½ g t² = 0.196 m
  EXPECT_LT(e.particles().z[0], z_before - 0.05);
}

// Particles that leave while no wall is open went through a gap the scene did not plan: the run
// counts them (RunSummary; the kFlagLeftUnplanned flag, which summary.json counts). A disk at rest
// on a trapdoor that opens at t = 0.05 s falls and leaves: planned. With the trapdoor moved out of
// its way and never opened, the same disk falls through the gap: unplanned (1 of 2 > 1 %).
TEST(DemRun, ParticlesLeavingThroughAnUnplannedGapAreCounted) {
  const std::string text = R"(
[scene]
name = "gap"
solvers = ["dem"]
duration = 0.5

[domain]
polygon = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]

[soil.dem]
count = 2
radius = { equal = 0.05 }
density = 2650
kn = 1.0e6
ks = 3.0e5
particles = [[-0.3, 0.05, 0.05, 0.0, 0.0, 0.0], [0.3, 0.05, 0.05, 0.0, 0.0, 0.0]]

[[wall]]
name = "floor"
points = [[-0.5, 0.0], [0.0, 0.0]]

[[wall]]
name = "trapdoor"
points = [[0.0, 0.0], [0.5, 0.0]]
opens_at = 0.05

[output]
interval = 0.1
probe_interval = 0.01

[[variant]]
name = "gap"
set = { "wall.trapdoor.points" = [[0.4, 0.4], [0.5, 0.4]], "wall.trapdoor.opens_at" = 1.0e3 }
)";
  const auto file = scene::parse_scene(text, "gap.toml", demfem::app::vocabulary());
  for (const std::string v : {"", "gap"}) {
    dem::RunOptions o;
    o.out_dir = scratch("gap_" + v);
    const auto s = dem::run(v.empty() ? file.base : file.select(v), o);
    ASSERT_TRUE(s.ok) << s.message;
    EXPECT_EQ(s.particles_left_unplanned, v.empty() ? 0u : 1u) << v;
  }
}
