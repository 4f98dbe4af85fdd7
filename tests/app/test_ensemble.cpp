// `demfem compare --seeds`: one comparison per packing seed, then ensemble.json and
// ensemble.html summarising each metric over the realisations. On a tiny packed bed against a
// fixed wall under shaking: the seed reaches the DEM's packing (its at-rest thrust differs between
// seeds) and not the continuum (identical), the statistics are those of the members' metrics.json,
// bad seed lists are refused before anything runs, and --report-only rebuilds the ensemble.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_util.hpp"

#ifdef DEMFEM_TEST_CONTINUUM
namespace fs = std::filesystem;

using demfem::test::run;
using demfem::test::scratch;
using demfem::test::slurp;
using demfem::test::write_temp;

namespace {

std::string tiny_scene(const fs::path& cache) {
  return "[scene]\n"
         "name = \"tiny-ensemble\"\n"
         "solvers = [\"dem\", \"continuum\"]\n"
         "duration = 0.1\n"
         "seed = 7\n"
         "[domain]\n"
         "polygon = [[0, 0], [0.6, 0], [0.6, 0.4], [0, 0.4]]\n"
         "[soil.dem]\n"
         "count = 60\n"
         "radius = { uniform = [0.015, 0.025] }\n"
         "kn = 1.0e6\n"
         "ks = 3.0e5\n"
         "[soil.dem.packing]\n"
         "damping = 0.05\n"
         "max_time = 4\n"
         "cache = \"" +
         cache.string() +
         "\"\n"
         "[soil.continuum]\n"
         "model = \"elastic\"\n"
         "young = 3.0e7\n"
         "poisson = 0.3\n"
         "density = 2000\n"
         "k0 = 0.5\n"
         "surface = 0.15\n"
         "[continuum]\n"
         "refinement = 0\n"
         "degree = 1\n"
         "dt = 0.01\n"
         "linear_solver = \"direct\"\n"
         "[[wall]]\n"
         "name = \"base\"\n"
         "points = [[0, 0], [0.6, 0]]\n"
         "[[wall]]\n"
         "name = \"left\"\n"
         "points = [[0, 0.4], [0, 0]]\n"
         "[[structure]]\n"
         "name = \"wall\"\n"
         "kind = \"wall\"\n"
         "shape = \"segment\"\n"
         "from = [0.6, 0]\n"
         "to = [0.6, 0.4]\n"
         "thickness = 0.05\n"
         "record = [\"thrust\"]\n"
         "[load]\n"
         "gravity = 9.81\n"
         "shaking = { direction = \"x\", amplitude = 1.0, frequency = 10.0, start = 0.05 }\n"
         "[output]\n"
         "vtk = false\n"
         "figures = false\n"
         "probe_interval = 0.005\n";
}

const nlohmann::json* row_of(const nlohmann::json& j, const std::string& key) {
  for (const auto& r : j["rows"])
    if (r["key"] == key) return &r;
  return nullptr;
}

} // namespace

TEST(CompareEnsemble, OneComparisonPerSeedAndTheirSummary) {
  const fs::path out = scratch("ensemble");
  fs::remove_all(out);
  const fs::path scene = write_temp("tiny_ensemble.toml", tiny_scene(out / "cache"));
  const auto r = run("compare " + scene.string() + " --seeds 1,2 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;

  std::ifstream in(out / "ensemble.json");
  ASSERT_TRUE(in) << r.out;
  const auto j = nlohmann::json::parse(in);
  ASSERT_EQ(j["members"].size(), 2U);
  EXPECT_EQ(j["members"][0]["seed"], 1);
  EXPECT_EQ(j["members"][1]["seed"], 2);
  EXPECT_TRUE(j["missing"].empty());
  EXPECT_NE(j["command"].get<std::string>().find("--seeds 1,2"), std::string::npos);
  for (const char* seed : {"1", "2"}) {
    const fs::path m = out / (std::string("seed-") + seed);
    EXPECT_TRUE(fs::exists(m / "report.html")) << m;
    EXPECT_TRUE(fs::exists(m / "metrics.json")) << m;
    // the member ran with that seed (its resolved scene), not the file's 7
    EXPECT_NE(slurp(m / "scene.resolved.toml").find(std::string("seed = ") + seed),
              std::string::npos);
  }

  const auto* thrust = row_of(j, "wall.thrust");
  ASSERT_NE(thrust, nullptr) << j.dump(1);
  const auto& st = (*thrust)["static"];
  const double d1 = st["dem"][0], d2 = st["dem"][1], c1 = st["continuum"][0],
               c2 = st["continuum"][1];
  std::printf("at-rest thrust: DEM %.4g / %.4g N, continuum %.4g / %.4g N\n", d1, d2, c1, c2);
  EXPECT_GT(d1, 0.0);
  EXPECT_GT(d2, 0.0);
  EXPECT_NE(d1, d2);                                // the seed reached the packing …
  EXPECT_NEAR(c1, c2, 1e-9 * std::abs(c1) + 1e-12); // … and not the continuum
  // the statistics are those of the members' own metrics.json
  for (int k = 0; k < 2; ++k) {
    std::ifstream mi(out / (k == 0 ? "seed-1" : "seed-2") / "metrics.json");
    const auto mj = nlohmann::json::parse(mi);
    const auto* mr = row_of(mj, "wall.thrust");
    ASSERT_NE(mr, nullptr);
    EXPECT_EQ((*mr)["static"]["dem"].get<double>(), st["dem"][k].get<double>());
  }
  EXPECT_EQ(st["dem_stats"]["min"].get<double>(), std::min(d1, d2));
  EXPECT_EQ(st["dem_stats"]["max"].get<double>(), std::max(d1, d2));
  EXPECT_DOUBLE_EQ(st["dem_stats"]["median"].get<double>(), 0.5 * (d1 + d2));
  EXPECT_EQ(st["with_both"], 2);
  // larger by more than 0.1 %: the DEM's here (its bed is denser than K0 = 0.5 says), in both
  const auto larger = [](double a, double b) {
    return std::abs(a) - std::abs(b) > 1e-3 * std::max(std::abs(a), std::abs(b));
  };
  EXPECT_EQ(st["dem_larger"].get<int>(), int(larger(d1, c1)) + int(larger(d2, c2)));
  EXPECT_EQ(st["continuum_larger"].get<int>(), int(larger(c1, d1)) + int(larger(c2, d2)));
  if (st["dem_larger"] == 2) {
    EXPECT_EQ(st["decision"], "the DEM's is larger in every realisation");
  }
  EXPECT_FALSE((*thrust)["verdict"].get<std::string>().empty());

  const std::string html = slurp(out / "ensemble.html");
  EXPECT_NE(html.find("seed-1/report.html"), std::string::npos);
  EXPECT_NE(html.find("seed-2/report.html"), std::string::npos);
  EXPECT_NE(html.find("wall thrust"), std::string::npos);

  // --report-only: nothing runs, the ensemble is rebuilt from the members
  fs::remove(out / "ensemble.json");
  const auto ro =
      run("compare " + scene.string() + " --seeds 1,2 --report-only --out " + out.string());
  ASSERT_EQ(ro.code, 0) << ro.out;
  EXPECT_TRUE(fs::exists(out / "ensemble.json"));
}

TEST(CompareEnsemble, BadSeedListsAreRefusedBeforeAnythingRuns) {
  const fs::path out = scratch("ensemble_bad");
  fs::remove_all(out);
  const fs::path scene = write_temp("tiny_ensemble_bad.toml", tiny_scene(out / "cache"));
  for (const std::string& args :
       {std::string(" --seeds 1,1"), std::string(" --seed 3 --seeds 1,2")}) {
    const auto r = run("compare " + scene.string() + args + " --out " + out.string());
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("--seeds"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(out / "seed-1")) << args;
  }
}
#endif
