// `demfem study error-vs-time` end to end: the DEM head-on collision swept in
// Δt, every run its own process; the order fitted by the study must match the theory.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>

#include "cli_util.hpp"
#include <nlohmann/json.hpp>

namespace fs = std::filesystem;

namespace {
using demfem::test::slurp;
} // namespace

// Elastic head-on collision (the base scene: approach 0.8 m/s < V_0): the centre distance after
// the rebound converges at order 2 in Δt (the engine's symplectic Euler gives Störmer–Verlet
// positions; its energy-consistent touch and release keep the contact switch from costing an
// order). Measured 1.996 over Δt = 1/16 … 1/1024 of the critical step; this tiny sweep (4
// settings, 1/16 … 1/128, one run each) must fit 2 ± 0.25. A first-order contact treatment
// (order ≈ 1) fails it.
TEST(StudyErrorVsTime, HeadOnCollisionSecondOrderInDt) {
  const fs::path out = fs::temp_directory_path() / ("demfem_evt_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const std::string cmd = std::string(DEMFEM_BINARY) +
                          " study error-vs-time " DEMFEM_SOURCE_DIR
                          "/cases/verification/head_on_collision.toml --repeats 1 --jobs 2 "
                          "--dt-fractions 0.0625,0.03125,0.015625,0.0078125 --kn-factors 1,10 "
                          "--out " +
                          out.string() + " > " + (out.string() + ".log") + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(out.string() + ".log");
  const auto j = nlohmann::json::parse(slurp(out / "study.json"));
  EXPECT_EQ(j.at("solver"), "dem");
  EXPECT_EQ(j.at("expected_order").get<double>(), 2.0);
  double order = NAN;
  for (const auto& f : j.at("fits"))
    if (f.at("knob") == "dt" && f.at("metric") == "distance" && f.at("against") == "dt") {
      ASSERT_FALSE(f.at("order").is_null());
      order = f.at("order").get<double>();
      EXPECT_EQ(f.at("points").get<int>(), 4);
    }
  EXPECT_NEAR(order, 2.0, 0.25) << slurp(out / "study.md");
  // every setting ran, with its timing and memory; the rebound speed of an elastic collision is
  // exact (energy-consistent springs) to round-off
  ASSERT_EQ(j.at("points").size(), 6u);
  for (const auto& p : j.at("points")) {
    EXPECT_TRUE(p.at("ok").get<bool>()) << p.dump();
    EXPECT_GT(p.at("wall_median").get<double>(), 0.0);
    EXPECT_GT(p.at("process_median").get<double>(), 0.0);
    EXPECT_GT(p.at("peak_rss_mib").get<double>(), 1.0);
    EXPECT_LT(p.at("errors").at("separation_speed").get<double>(), 1e-9) << p.dump();
  }
  EXPECT_NE(slurp(out / "study.html").find("Pareto"), std::string::npos);
  EXPECT_TRUE(fs::exists(out / "figures" / "convergence_dt.png"));
  EXPECT_TRUE(fs::exists(out / "figures" / "error_vs_wall_dt.png"));
  fs::remove_all(out);
  fs::remove(out.string() + ".log");
}

// A scene without a closed form is refused (exit 2) and nothing runs.
TEST(StudyErrorVsTime, SceneWithoutClosedFormIsRefused) {
  const fs::path out = fs::temp_directory_path() / ("demfem_evt2_" + std::to_string(::getpid()));
  const std::string cmd = std::string(DEMFEM_BINARY) +
                          " study error-vs-time " DEMFEM_SOURCE_DIR
                          "/cases/verification/two_disk_column.toml --out " +
                          out.string() + " > " + (out.string() + ".log") + " 2>&1";
  const int st = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(st), 2) << slurp(out.string() + ".log");
  EXPECT_NE(slurp(out.string() + ".log").find("closed form"), std::string::npos);
  EXPECT_FALSE(fs::exists(out / "study.json"));
  fs::remove_all(out);
  fs::remove(out.string() + ".log");
}

#ifdef DEMFEM_TEST_CONTINUUM
namespace {
// A tiny two-solver scene without a closed form: ~150 disks deposited in a 1 m box against a
// fixed wall, shaken at 10 Hz from t = 0.3 s (the late window of the metric split needs about
// 1 s of loading: split_options); the continuum a Mohr–Coulomb box with stated parameters.
std::string tiny_wall(const fs::path& cache) {
  return R"(
[scene]
name = "tiny-evt"
solvers = ["dem", "continuum"]
duration = 1.0
seed = 5

[domain]
polygon = [[0, 0], [1.0, 0], [1.0, 0.5], [0, 0.5]]

[soil.dem]
count = 150
radius = { uniform = [0.02, 0.03] }
density = 2650
kn = 1.0e6
ks = 3.0e5
mu_static = 0.5
mu_dynamic = 0.3

[soil.dem.packing]
damping = 0.05
max_time = 10
cache = ")" +
         cache.string() +
         R"("

[soil.continuum]
model = "mohr-coulomb"
young = 2.0e7
poisson = 0.3
friction_angle = 30
cohesion = 1.0e3
density = 1800
surface = 0.3

[continuum]
refinement = 1
degree = 1
integrator = "explicit"
linear_solver = "direct"

[[wall]]
name = "base"
points = [[0, 0], [1.0, 0]]

[[wall]]
name = "left"
points = [[0, 0.5], [0, 0]]

[[structure]]
name = "wall"
kind = "wall"
shape = "segment"
from = [1.0, 0]
to = [1.0, 0.5]
thickness = 0.05
dof_x = "fixed"
dof_z = "fixed"
dof_rotation = "fixed"

[load]
gravity = 9.81
shaking = { direction = "x", amplitude = 2.0, frequency = 10.0, start = 0.3 }

[[probe]]
kind = "wall-thrust"
target = "wall"

[[probe]]
kind = "surface-profile"
bins = 8

[output]
interval = 0.05
probe_interval = 0.005
)";
}
} // namespace

// Error-vs-time on a scene without a closed form — both solvers, each against its most
// resolved run, measured with the comparison's metric table (wall thrust static value, mean
// increment and oscillation amplitude; surface), with the fronts and figures of the closed-form
// studies. The DEM Δt settings share one packing.
TEST(StudyErrorVsTime, TwoSolverSceneAgainstMostResolvedRun) {
  const fs::path out = demfem::test::scratch("evt_scene");
  const fs::path scene = out / "tiny.toml";
  fs::create_directories(out);
  std::ofstream(scene) << tiny_wall(out / "packings");
  const std::string cmd = std::string(DEMFEM_BINARY) + " study error-vs-time " + scene.string() +
                          " --repeats 1 --jobs 2 --dt-fractions 0.5,0.25 --kn-factors 1 "
                          "--refinements 0,1 --degrees 1 --integrators explicit --out " +
                          (out / "study").string() + " > " + (out / "log").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(out / "log");
  const auto j = nlohmann::json::parse(slurp(out / "study" / "study.json"));
  EXPECT_EQ(j.at("solver"), "both");
  EXPECT_EQ(j.at("reference_runs").at("dem"), "dem-dt-1/4");
  EXPECT_EQ(j.at("reference_runs").at("continuum"), "cont-q1-r1-explicit");
  // particle size at fixed geometry (default factors 1, 4): against the most particles
  EXPECT_EQ(j.at("reference_runs").at("dem-size"), "dem-size-x4");
  // continuum Δt (default 1, 0.5, 0.25 × the automatic step on the coarsest mesh): the smallest
  EXPECT_EQ(j.at("reference_runs").at("continuum-dt"), "cont-dt-x0.25-q1-r0-explicit");
  EXPECT_NE(j.at("reference").get<std::string>().find("most resolved"), std::string::npos);
  const std::string primary = j.at("primary_metric");
  EXPECT_EQ(primary.rfind("wall.thrust.", 0), 0u) << primary;
  EXPECT_TRUE(j.at("metrics").contains("wall.thrust.static")) << j.at("metrics").dump();
  ASSERT_EQ(j.at("points").size(), 10u);
  for (const auto& p : j.at("points")) {
    EXPECT_TRUE(p.at("ok").get<bool>()) << p.dump();
    const std::string name = p.at("name");
    const bool ref = name == "dem-dt-1/4" || name == "cont-q1-r1-explicit" ||
                     name == "dem-size-x4" || name == "cont-dt-x0.25-q1-r0-explicit";
    // every other run has the primary error, a finite non-negative number
    if (!ref) {
      ASSERT_TRUE(p.at("errors").contains(primary)) << p.dump();
      EXPECT_GE(p.at("errors").at(primary).get<double>(), 0.0);
    } else {
      EXPECT_TRUE(p.at("errors").empty()) << p.dump();
    }
    EXPECT_GT(p.at("wall_median").get<double>(), 0.0);
  }
  // The size points: 150 disks of mean radius 0.025 m and 600 of 0.0125 m in the same box. The
  // same solid area makes the same bed, so the at-rest thrust (≈ ½K0γH²) stays within 30 %; radii
  // halved without 4× the count would make a bed of half the height, a quarter of the thrust.
  std::map<std::string, nlohmann::json> pts;
  for (const auto& p : j.at("points")) pts[p.at("name")] = p;
  ASSERT_TRUE(pts.count("dem-size-x1") && pts.count("dem-size-x4")) << j.at("points").dump();
  const auto& s1 = pts["dem-size-x1"];
  const auto& s4 = pts["dem-size-x4"];
  EXPECT_EQ(s1.at("knob"), "size");
  EXPECT_EQ(s1.at("results").at("count").get<double>(), 150.0);
  EXPECT_EQ(s4.at("results").at("count").get<double>(), 600.0);
  EXPECT_NEAR(s1.at("x").get<double>(), 0.025, 1e-12);
  EXPECT_NEAR(s4.at("x").get<double>(), 0.0125, 1e-12);
  EXPECT_LT(s4.at("dt").get<double>(), 0.6 * s1.at("dt").get<double>()); // automatic: Δt ∝ r
  // the damped deposition falls √f times slower: × 4 gets twice the scene's 10 s to land
  for (const auto& [point, want] :
       {std::pair{"dem-size-x1", 10.0}, std::pair{"dem-size-x4", 20.0}}) {
    const std::string toml = slurp(out / "study" / "runs" / point / "scene.toml");
    const auto at = toml.find("max_time = ");
    ASSERT_NE(at, std::string::npos) << toml;
    EXPECT_DOUBLE_EQ(std::stod(toml.substr(at + 11)), want) << point;
  }
  ASSERT_TRUE(s1.at("errors").contains("wall.thrust.static")) << s1.dump();
  EXPECT_LT(s1.at("errors").at("wall.thrust.static").get<double>(), 0.3) << s1.dump();
  // the continuum Δt points: steps in the ratios asked for, the step as their abscissa
  ASSERT_TRUE(pts.count("cont-dt-x1-q1-r0-explicit") && pts.count("cont-dt-x0.5-q1-r0-explicit"))
      << j.at("points").dump();
  const auto& c1 = pts["cont-dt-x1-q1-r0-explicit"];
  const auto& c5 = pts["cont-dt-x0.5-q1-r0-explicit"];
  EXPECT_EQ(c1.at("knob"), "cont-dt");
  EXPECT_NEAR(c5.at("dt").get<double>() / c1.at("dt").get<double>(), 0.5, 1e-9);
  EXPECT_EQ(c1.at("x").get<double>(), c1.at("dt").get<double>());
  EXPECT_TRUE(c1.at("errors").contains(primary)) << c1.dump();
  bool same_packing = false, size_note = false, near_note = false;
  for (const auto& n : j.at("notes")) {
    const std::string t = n;
    same_packing = same_packing || t.find("scene's packing") != std::string::npos;
    size_note = size_note || t.find("DEM particle size points") != std::string::npos;
    near_note = near_note || t.find("mesh_size_near points: not applicable") != std::string::npos;
  }
  EXPECT_TRUE(same_packing) << j.at("notes").dump();
  EXPECT_TRUE(size_note) << j.at("notes").dump();
  EXPECT_TRUE(near_note) << j.at("notes").dump(); // the tiny scene's mesh is uniform
  for (const char* f :
       {"error_vs_wall_dem_dt.png", "error_vs_wall_dem_size.png", "convergence_size.png",
        "error_vs_wall_continuum.png", "error_vs_wall_continuum_dt.png",
        "convergence_continuum_dt.png", "error_vs_wall_both.png"})
    EXPECT_TRUE(fs::exists(out / "study" / "figures" / f)) << f;
  EXPECT_NE(slurp(out / "study" / "study.html").find("most resolved"), std::string::npos);
}
#endif

#ifdef DEMFEM_TEST_CONTINUUM
// A scene with continuum.interface = "coulomb" (explicit only): the implicit knob is skipped and
// listed with its reason, not run into a refusal (the implicit runs used to exit 2 each).
TEST(StudyErrorVsTime, CoulombSceneSkipsTheImplicitKnobWithItsReason) {
  const fs::path out = demfem::test::scratch("evt_coulomb");
  const fs::path scene = out / "tiny.toml";
  fs::create_directories(out);
  std::string text = tiny_wall(out / "packings");
  const std::string key = "integrator = \"explicit\"\n";
  text.replace(text.find(key), key.size(), key + "interface = \"coulomb\"\n");
  std::ofstream(scene) << text;
  const std::string cmd = std::string(DEMFEM_BINARY) + " study error-vs-time " + scene.string() +
                          " --solver continuum --repeats 1 --jobs 2 --refinements 0,1 --degrees 1 "
                          "--integrators explicit,implicit --continuum-dt-factors none "
                          "--duration 0.5 --out " +
                          (out / "study").string() + " > " + (out / "log").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(out / "log");
  const auto j = nlohmann::json::parse(slurp(out / "study" / "study.json"));
  for (const auto& p : j.at("points")) {
    EXPECT_EQ(p.at("name").get<std::string>().find("implicit"), std::string::npos) << p.dump();
    EXPECT_TRUE(p.at("ok").get<bool>()) << p.dump();
  }
  bool listed = false;
  for (const auto& n : j.at("notes"))
    listed = listed || n.get<std::string>().find("mesh-q1-implicit skipped: continuum.interface "
                                                 "= \"coulomb\"") != std::string::npos;
  EXPECT_TRUE(listed) << j.at("notes").dump();
}

// A graded continuum mesh (mesh_size_near > 0) is swept in mesh_size_near at the
// scene's refinement; the finest is the continuum's reference (the most dofs).
TEST(StudyErrorVsTime, GradedMeshSweepsItsNearCellSize) {
  const fs::path out = demfem::test::scratch("evt_near");
  const fs::path scene = out / "tiny.toml";
  fs::create_directories(out);
  std::string text = tiny_wall(out / "packings");
  const std::string key = "integrator = \"explicit\"\n";
  text.replace(text.find(key), key.size(), key + "mesh_size_near = 0.05\n");
  std::ofstream(scene) << text;
  const std::string cmd = std::string(DEMFEM_BINARY) + " study error-vs-time " + scene.string() +
                          " --solver continuum --repeats 1 --jobs 2 --refinements 0 --degrees 1 "
                          "--integrators explicit --near-factors 2,1 --continuum-dt-factors none "
                          "--duration 0.5 --out " +
                          (out / "study").string() + " > " + (out / "log").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(out / "log");
  const auto j = nlohmann::json::parse(slurp(out / "study" / "study.json"));
  std::vector<nlohmann::json> near;
  for (const auto& p : j.at("points")) {
    EXPECT_TRUE(p.at("ok").get<bool>()) << p.dump();
    if (p.at("knob") == "mesh-near") near.push_back(p);
  }
  ASSERT_EQ(near.size(), 2u) << j.at("points").dump();
  EXPECT_EQ(near[0].at("name"), "cont-near-x2-q1-r1-explicit"); // coarse first
  EXPECT_EQ(near[1].at("name"), "cont-near-x1-q1-r1-explicit");
  EXPECT_GT(near[1].at("dofs").get<std::size_t>(), near[0].at("dofs").get<std::size_t>());
  EXPECT_EQ(j.at("reference_runs").at("continuum"), "cont-near-x1-q1-r1-explicit");
  EXPECT_TRUE(near[0].at("errors").contains(j.at("primary_metric").get<std::string>()))
      << near[0].dump();
  bool noted = false;
  for (const auto& n : j.at("notes"))
    noted = noted || n.get<std::string>().find("the scene's 0.05 m × 2, 1 at refinement 1") !=
                         std::string::npos;
  EXPECT_TRUE(noted) << j.at("notes").dump();

  // a malformed list is refused before anything runs, naming the option and the entry
  const std::string bad = std::string(DEMFEM_BINARY) + " study error-vs-time " + scene.string() +
                          " --near-factors 2,x --out " + (out / "bad").string() + " > " +
                          (out / "bad.log").string() + " 2>&1";
  EXPECT_EQ(WEXITSTATUS(std::system(bad.c_str())), 2);
  const std::string log = slurp(out / "bad.log");
  EXPECT_NE(log.find("--near-factors"), std::string::npos) << log;
  EXPECT_NE(log.find("'x'"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(out / "bad" / "study.json"));

  // a particle size factor that does not make a whole count (150 × 0.33) is refused up front
  const std::string odd = std::string(DEMFEM_BINARY) + " study error-vs-time " + scene.string() +
                          " --size-factors 1,0.33 --out " + (out / "odd").string() + " > " +
                          (out / "odd.log").string() + " 2>&1";
  EXPECT_EQ(WEXITSTATUS(std::system(odd.c_str())), 2);
  const std::string odd_log = slurp(out / "odd.log");
  EXPECT_NE(odd_log.find("--size-factors 0.33 gives 49.5 particles"), std::string::npos) << odd_log;
  EXPECT_FALSE(fs::exists(out / "odd"));
}
#endif
