// DEM stability classes: each run either completes within its energy bound
// or stops (or is refused) with its specific diagnostic. Small scenes, each well under 10 s.
// The energy bound of a completed run: the end-of-run |ΔE_total| / (|gravity work|
// + |external work|) below the default warning level soil.dem.energy_warning = 0.05; the numbers
// measured when the tests were written are in the comments.
#include <gtest/gtest.h>

#include "../scratch.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/dem/stable_step.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/validate.hpp"

using namespace demfem;

namespace {

struct P {
  double x, z, r;
};

// A box 0.8 m × 1.2 m (walls left, base, right) holding the listed particles at rest.
std::string box_scene(const std::string& name, const std::vector<P>& parts, double kn, double mu,
                      double duration, const std::string& extra = "") {
  std::string ps;
  double rmin = 1e300, rmax = 0;
  for (const auto& p : parts) {
    ps += fmt::format("{}[{}, {}, {}, 0.0, 0.0, 0.0]", ps.empty() ? "" : ", ", p.x, p.z, p.r);
    rmin = std::min(rmin, p.r);
    rmax = std::max(rmax, p.r);
  }
  const std::string radius = rmin == rmax ? fmt::format("{{ equal = {} }}", rmin)
                                          : fmt::format("{{ uniform = [{}, {}] }}", rmin, rmax);
  return fmt::format(R"([scene]
name = "{}"
duration = {}
[domain]
polygon = [[0, 0], [0.8, 0], [0.8, 1.2], [0, 1.2]]
[soil.dem]
count = {}
radius = {}
kn = {}
ks = {}
mu_static = {}
mu_dynamic = {}
{}
particles = [{}]
[[wall]]
name = "box"
points = [[0, 1.2], [0, 0], [0.8, 0], [0.8, 1.2]]
[output]
vtk = false
probe_interval = 0.01
)",
                     name, duration, parts.size(), radius, kn, 0.3 * kn, mu, 0.8 * mu, extra, ps);
}

// 24 disks r = 0.05 m in 4 rows of 6, 0.4–3 cm apart, released at rest.
std::vector<P> bed24() {
  std::vector<P> v;
  for (int k = 0; k < 24; ++k)
    v.push_back({0.09 + 0.12 * (k % 6) + 0.004 * (k % 5), 0.08 + 0.13 * (k / 6), 0.05});
  return v;
}

// Two-disk column on a floor: r = 0.05 m, K_n = 1e6 N/m, dropped 1 mm.
std::string column_scene(double dt, const std::string& extra = "") {
  return fmt::format(R"([scene]
name = "column"
duration = 1.0
[domain]
polygon = [[-0.5, 0.0], [0.5, 0.0], [0.5, 1.0], [-0.5, 1.0]]
[soil.dem]
count = 2
radius = {{ equal = 0.05 }}
kn = 1.0e6
ks = 3.0e5
dt = {:.17g}
{}
particles = [[0.0, 0.051, 0.05, 0.0, 0.0, 0.0], [0.0, 0.152, 0.05, 0.0, 0.0, 0.0]]
[[wall]]
name = "floor"
points = [[-0.5, 0.0], [0.5, 0.0]]
[output]
vtk = false
probe_interval = 0.01
)",
                     dt, extra);
}
// Its stable limit √(m/(2K_n)) (stable_step.hpp, disks, k_s ≤ k_n/3).
double column_limit() {
  return std::sqrt(2650.0 * std::numbers::pi * 0.05 * 0.05 / 2.0e6);
}

struct Outcome {
  dem::RunSummary s;
  double closure = std::nan("");
  double max_kinetic = 0.0; // over energy.csv [J]
  double gravity_work = 0.0;
  double imbalance = 0.0; // end of run [J]
};

double json_number(const std::string& text, const std::string& key) {
  const auto k = text.find("\"" + key + "\"");
  return k == std::string::npos ? std::nan("") : std::stod(text.substr(text.find(':', k) + 1));
}

Outcome run_scene(const std::string& toml, const std::string& name) {
  const auto file = scene::parse_scene(toml, name + ".toml", demfem::app::vocabulary());
  dem::RunOptions o;
  o.out_dir = demfem::test::scratch(name);
  Outcome r;
  r.s = dem::run(file.base, o);
  std::ifstream in(o.out_dir / "dem" / "energy_budget.json");
  std::stringstream ss;
  ss << in.rdbuf();
  // The bound these tests state: the imbalance over the work done (gravity and external). The
  // run's own closure_error divides by the largest energy put in, springs included
  // (energy_watch.cpp), which is never smaller: this is the stricter of the two.
  r.gravity_work = json_number(ss.str(), "gravity_work");
  r.imbalance = json_number(ss.str(), "imbalance");
  const double work = std::abs(r.gravity_work) + std::abs(json_number(ss.str(), "external_work"));
  if (std::isfinite(r.imbalance) && work > 0.0) {
    r.closure = std::abs(r.imbalance) / work;
    EXPECT_LE(json_number(ss.str(), "closure_error"), r.closure * (1.0 + 1e-12)) << name;
  }
  std::ifstream csv(o.out_dir / "dem" / "energy.csv");
  std::string line;
  while (std::getline(csv, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 't') continue;
    std::stringstream ls(line);
    std::string cell;
    std::vector<double> row;
    while (std::getline(ls, cell, ',')) row.push_back(std::stod(cell));
    if (row.size() > 2) r.max_kinetic = std::max(r.max_kinetic, row[1] + row[2]);
  }
  std::printf("%s: ok %d, %lld steps, closure %.3e, max kinetic %.4g J, gravity work %.4g J %s\n",
              name.c_str(), r.s.ok, r.s.steps, r.closure, r.max_kinetic, r.gravity_work,
              r.s.message.c_str());
  std::filesystem::remove_all(o.out_dir);
  return r;
}

} // namespace

// K_n × 1000 (1e9 N/m) with the automatic Δt: the step follows the stiffness (70 000 steps for
// 1 s) and the budget closes (measured 7.0e-3).
TEST(DemStability, StiffContactsWithAutomaticStepComplete) {
  const auto r = run_scene(box_scene("kn1000", bed24(), 1.0e9, 0.5, 1.0), "kn1000");
  ASSERT_TRUE(r.s.ok) << r.s.message;
  EXPECT_GT(r.s.steps, 50000);
  EXPECT_LT(r.closure, 0.05);
}

// Δt = 0.9 × the stable limit on the issue's two-disk column completes, its kinetic energy
// bounded by the work of gravity (no growth); 1.1 × is refused at setup: by the scene check at
// the dt key's line (what check and run do), and by the engine when the vocabulary has no limit.
// (At 0.9 × the limit the contacts last ≈ 3.5 steps: the budget loses energy at each impact of
// the bouncing column, closure 0.84 after 1 s; it is stable, not accurate.)
TEST(DemStability, TwoDiskColumnStableBelowAndRefusedAboveTheLimit) {
  const auto ok = run_scene(column_scene(0.9 * column_limit()), "column09");
  ASSERT_TRUE(ok.s.ok) << ok.s.message;
  EXPECT_LT(ok.max_kinetic, ok.gravity_work + 0.5); // 2·m·g·1 mm + the bounce's spring energy

  const std::string bad = column_scene(1.1 * column_limit());
  try {
    (void)scene::parse_scene(bad, "column11.toml", demfem::app::vocabulary());
    ADD_FAILURE() << "expected the scene check to refuse dt";
  } catch (const scene::SceneError& e) {
    const auto& d = e.diagnostics().at(0);
    EXPECT_EQ(d.key, "soil.dem.dt");
    EXPECT_EQ(d.line, 11); // the dt line of column_scene
    EXPECT_NE(d.message.find("above the stable limit"), std::string::npos) << d.message;
  }
  scene::Vocabulary no_limit = demfem::app::vocabulary();
  no_limit.dem_step_limit = nullptr;
  const auto file = scene::parse_scene(bad, "column11.toml", no_limit); // no check
  dem::RunOptions o;
  o.out_dir = demfem::test::scratch("column11");
  EXPECT_THROW((void)dem::run(file.base, o), scene::SceneError);
  std::filesystem::remove_all(o.out_dir);
}

// The energy-closure watch stops a run past soil.dem.energy_limit with exit-1 diagnostics:
// step, time, the closure and the largest-energy particle. (The column at 0.9 × the limit loses
// ≈ 17 % of its budget in the first bounces; a limit of 1 % stops it.)
TEST(DemStability, EnergyLimitStopsTheRunNamingStepTimeAndParticle) {
  const auto r =
      run_scene(column_scene(0.9 * column_limit(), "energy_limit = 0.01"), "column_limit");
  ASSERT_FALSE(r.s.ok);
  for (const char* s : {"stopped at step", "t = ", "energy closure error", "energy_limit = 0.01",
                        "largest-energy particle: id "})
    EXPECT_NE(r.s.message.find(s), std::string::npos) << s << " in " << r.s.message;
}

// Frictionless (μ = 0) and very rough (μ = 2) beds settle and close their budget (measured
// 8.0e-4 and 3.1e-2).
TEST(DemStability, FrictionlessAndRoughBedsComplete) {
  for (const double mu : {0.0, 2.0}) {
    const auto r = run_scene(box_scene(fmt::format("mu{}", mu), bed24(), 1.0e6, mu, 1.0),
                             fmt::format("mu{}", mu));
    ASSERT_TRUE(r.s.ok) << "μ = " << mu << ": " << r.s.message;
    EXPECT_LT(r.closure, 0.05) << "μ = " << mu;
  }
}

// Radius ratio 10: a disk r = 0.25 m (100 × the mass) lowered onto 36 disks r = 0.025 m; the
// automatic Δt follows the small disks (measured closure 7.8e-4).
TEST(DemStability, RadiusRatioTenCompletes) {
  std::vector<P> v;
  for (int k = 0; k < 36; ++k) v.push_back({0.05 + 0.06 * (k % 12), 0.03 + 0.06 * (k / 12), 0.025});
  v.push_back({0.4, 0.426, 0.25});
  const auto r = run_scene(box_scene("ratio10", v, 1.0e7, 0.5, 1.0), "ratio10");
  ASSERT_TRUE(r.s.ok) << r.s.message;
  EXPECT_LT(r.closure, 0.05);
}

// 20 % initial overlap: 20 disks packed with every neighbour (and the base) overlapping by
// 0.2 r. The springs' energy (≈ 50 J a contact, kinetic energy up to 1.6e3 J) is released at
// once; the energy-jump check counts it as put in and the run completes. The imbalance is held
// to 1 % of the largest kinetic energy: measured 1.7–9.8 J (0.1–0.6 %) over K_n × (1 ± 4e-4),
// which turns the disks' later collisions chaotically. (Until 2026-11-26 this asked for a
// closure below 5 % of the gravity work, 141 J: 1.2e-2 here, but 0.012–0.057 over the same
// K_n factors, so it passed for this one realisation.)
TEST(DemStability, TwentyPercentInitialOverlapCompletes) {
  const double r = 0.05, d = 2 * r - 0.2 * r;
  std::vector<P> v;
  for (int k = 0; k < 20; ++k) v.push_back({0.1 + d * (k % 5), r - 0.2 * r + d * (k / 5), r});
  const auto o = run_scene(box_scene("overlap20", v, 1.0e6, 0.5, 1.0), "overlap20");
  ASSERT_TRUE(o.s.ok) << o.s.message;
  EXPECT_GT(o.max_kinetic, 1.0e3);
  EXPECT_LT(std::abs(o.imbalance), 0.01 * o.max_kinetic);
}

// The friction cap sees the spring force, not the rebound impulse (dem/contact/rebound.hpp): a disk
// hitting a floor at 2 m/s normal and 1 m/s tangential speed (μ = 0.5, K = 0.1) keeps 0.80 of its
// tangential speed; Newton restitution with Coulomb friction on the impulse would keep at most 2/3
// (the rolling limit of a disk). A modelling choice, documented.
TEST(DemStability, FrictionCapSeesTheSpringForceNotTheReboundImpulse) {
  dem::EngineConfig c;
  c.law = dem::contact::make_law(
      "cundall-rebound", {{"kn", 1.0e6}, {"ks", 3.0e5}, {"rebound", 0.1}, {"rebound_speed", 1.0}});
  c.gravity = 0.0;
  c.materials = {dem::Material{0.5, 0.5}};
  dem::Engine e(c);
  e.add_wall({{-1.0, 0.0}, {1.0, 0.0}}, "floor");
  e.add_particle(0.0, 0.0505, 0.05, 1.0, -2.0);
  e.set_dt(e.auto_dt());
  while (e.time() < 0.05) e.step();
  const double kept = e.particles().vx[0] / 1.0;
  std::printf("tangential speed kept %.4f, rebound %.4f of the normal speed\n", kept,
              e.particles().vz[0] / 2.0);
  EXPECT_NEAR(kept, 0.80, 0.01);
  EXPECT_GT(kept, 2.0 / 3.0 + 0.1);
}
