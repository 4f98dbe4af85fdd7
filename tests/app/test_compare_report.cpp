// `demfem compare` end to end on a tiny two-solver scene: each solver records its run
// (<run>/run_<solver>.json) and the report shows the reproducing command, the run times and the
// "what differs between the two models" table built from that scene.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_util.hpp"

namespace fs = std::filesystem;
using demfem::test::Result;
using demfem::test::run;
using demfem::test::slurp;

#ifdef DEMFEM_TEST_CONTINUUM
namespace {
std::string fmt_row(double x, double z) { // one explicit particle: x, z, r, vx, vz, ω
  std::string row = "[";
  row.append(std::to_string(x)).append(", ").append(std::to_string(z));
  row.append(", 0.05, 0.0, 0.0, 0.0]");
  return row;
}
// Two disks on a 1 m floor against a left wall; an elastic continuum box (one Q1 cell level).
const char* kTiny = R"(
[scene]
name = "tiny-compare"
solvers = ["dem", "continuum"]
duration = 0.05

[domain]
polygon = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.3], [0.0, 0.3]]

[soil.dem]
count = 2
radius = { equal = 0.05 }
density = 2650
kn = 1.0e6
ks = 3.0e5
particles = [[0.3, 0.051, 0.05, 0.0, 0.0, 0.0], [0.6, 0.051, 0.05, 0.0, 0.0, 0.0]]

[soil.continuum]
model = "elastic"
young = 3.0e7
poisson = 0.3
density = 1700
k0 = 0.5

[continuum]
refinement = 0
degree = 1
dt = 0.01
linear_solver = "direct"

[[wall]]
name = "base"
points = [[0.0, 0.0], [1.0, 0.0]]

[[wall]]
name = "left"
points = [[0.0, 0.3], [0.0, 0.0]]

[load]
gravity = 9.81

[[probe]]
kind = "energy"

[output]
vtk = false
figures = false
probe_interval = 0.01
)";
} // namespace

TEST(CompareReport, RecordsRunsAndListsWhatDiffers) {
  const fs::path scene = demfem::test::write_temp("tiny.toml", kTiny);
  const fs::path out = demfem::test::scratch("tiny-run");
  const Result r = run("compare " + scene.string() + " --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* solver : {"dem", "continuum"}) {
    const auto j = nlohmann::json::parse(slurp(out / (std::string("run_") + solver + ".json")));
    EXPECT_TRUE(j["ok"].get<bool>()) << solver;
    EXPECT_GT(j["steps"].get<long long>(), 0) << solver;
    EXPECT_GT(j["dt_s"].get<double>(), 0.0) << solver;
    EXPECT_GT(j["total_seconds"].get<double>(), 0.0) << solver;
  }
  const auto c = nlohmann::json::parse(slurp(out / "run_continuum.json"));
  EXPECT_EQ(c["refinement"].get<int>(), 0);
  EXPECT_EQ(c["degree"].get<int>(), 1);
  EXPECT_GT(c["dofs"].get<long long>(), 0);

  const std::string html = slurp(out / "report.html");
  EXPECT_NE(html.find("Reproduce: <code>demfem compare " + scene.string() + " --out " +
                      out.string() + "</code>"),
            std::string::npos);
  EXPECT_NE(html.find("What differs between the two models"), std::string::npos);
  EXPECT_NE(html.find("Parameters of both models"), std::string::npos);
  const auto m = nlohmann::json::parse(slurp(out / "metrics.json"));
  std::map<std::string, nlohmann::json> rows;
  for (const auto& row : m["what_differs"]) rows[row["aspect"].get<std::string>()] = row;
  ASSERT_TRUE(rows.count("boundary: left side"));
  EXPECT_NE(rows["boundary: left side"]["dem"].get<std::string>().find("frictional wall 'left'"),
            std::string::npos);
  EXPECT_NE(rows["boundary: left side"]["continuum"].get<std::string>().find("roller"),
            std::string::npos);
  ASSERT_TRUE(rows.count("soil model (constitutive behaviour)"));
  EXPECT_NE(rows["soil model (constitutive behaviour)"]["continuum"].get<std::string>().find(
                "linear elastic"),
            std::string::npos);
  ASSERT_TRUE(rows.count("time integration"));
  EXPECT_NE(rows["time integration"]["continuum"].get<std::string>().find("implicit Newmark"),
            std::string::npos);
  // no calibration: mass and K0 are not matched, and the page says how to calibrate
  EXPECT_FALSE(rows["initial stress"]["matched"].get<bool>());
  EXPECT_NE(html.find("demfem calibrate " + scene.string()), std::string::npos);
  EXPECT_GT(m["run_times"]["dem"]["solver_seconds"].get<double>(), 0.0);
  // Listed particles are no realisation of anything: no seed ensemble is suggested
  // (Report.ComparesWallThrustAndPressureProfiles: a deposited bed is one).
  EXPECT_EQ(html.find("--seeds"), std::string::npos);
}

// The same scene with snapshots: two rows of disks on the floor. The coarse-grained DEM fields
// and the continuum's come out on the continuum's mesh in one ParaView file (both methods and their
// difference per field), and the force-chain files carry the particles' wall contacts.
TEST(CompareReport, FieldMapsOnTheContinuumMeshOpenInParaView) {
  std::string scene_text = kTiny;
  const auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = scene_text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    scene_text.replace(at, from.size(), to);
  };
  std::string rows = "particles = [";
  for (int k = 0; k < 9; ++k)
    rows.append(fmt_row(0.1 + 0.1 * k, 0.0497))
        .append(", ")
        .append(fmt_row(0.15 + 0.1 * k, 0.1362))
        .append(", ");
  rows.push_back(']');
  replace("count = 2\n", "count = 18\n");
  replace("particles = [[0.3, 0.051, 0.05, 0.0, 0.0, 0.0], [0.6, 0.051, 0.05, 0.0, 0.0, 0.0]]",
          rows);
  replace("vtk = false", "vtk = true\ninterval = 0.025");
  // at rest until 0.025 s (the fields' rest snapshot, once the contacts have formed), then shaken
  replace("gravity = 9.81\n", "gravity = 9.81\nshaking = { direction = \"x\", amplitude = 1.0, "
                              "frequency = 20.0, start = 0.025 }\n");
  const fs::path scene = demfem::test::write_temp("tiny_fields.toml", scene_text);
  const fs::path out = demfem::test::scratch("tiny-fields");
  const Result r = run("compare " + scene.string() + " --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string vtu = slurp(out / "compare" / "fields.vtu");
  ASSERT_FALSE(vtu.empty());
  EXPECT_NE(vtu.find("<VTKFile type=\"UnstructuredGrid\""), std::string::npos);
  for (const char* key : {"szz_rest", "sxx_rest", "ux_inc", "vol_inc"})
    for (const char* who : {"continuum ", "DEM ", "continuum - DEM "}) {
      std::string name = "Name=\"";
      name.append(who).append(key).push_back('"');
      EXPECT_NE(vtu.find(name), std::string::npos) << name;
    }
  EXPECT_NE(slurp(out / "report.html").find("compare/fields.vtu"), std::string::npos);
  // wall contacts in the force chains, so the coarse-grained stress holds up to the base
  bool boundary_array = false;
  for (const auto& e : fs::directory_iterator(out / "dem" / "vtk"))
    if (e.path().filename().string().starts_with("force_chains"))
      boundary_array =
          boundary_array || slurp(e.path()).find("Name=\"boundary\"") != std::string::npos;
  EXPECT_TRUE(boundary_array);
  EXPECT_NE(slurp(out / "report.html").find("includes the wall and base contacts"),
            std::string::npos);
}
#endif
