// studies::summarise_ensemble (issue 9, `demfem compare --seeds`): per part, which solver's
// magnitude is larger in how many realisations, with magnitudes within 0.1 % counted as equal, and
// what that decides; the statistics over the members; a member without metrics.json is left out
// with the reason.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "../scratch.hpp"
#include "demfem/studies/ensemble.hpp"

namespace fs = std::filesystem;
using demfem::studies::EnsembleMember;
using demfem::studies::summarise_ensemble;

namespace {
// A member directory with one metric row "b.rotation": amplitude (dem, continuum), static both v.
fs::path member(const std::string& name, double dem_amp, double cont_amp, double stat) {
  const fs::path d = demfem::test::scratch(name);
  fs::create_directories(d);
  nlohmann::json row = {{"key", "b.rotation"}, {"quantity", "rotation"}, {"unit", "rad"}};
  row["static"] = {{"dem", stat}, {"continuum", stat * (1 + 1e-5)}};
  row["mean_increment"] = {{"dem", nullptr}, {"continuum", 1e-6}};
  row["oscillation_amplitude"] = {{"dem", dem_amp}, {"continuum", cont_amp}};
  std::ofstream(d / "metrics.json") << nlohmann::json{{"rows", {row}}}.dump();
  return d;
}
} // namespace

TEST(EnsembleSummary, CountsDecidesAndTreatsNearEqualAsEqual) {
  const auto e = summarise_ensemble({{41, member("m41", 3e-4, 2e-4, 7.0)},
                                     {101, member("m101", 1e-2, 2e-4, 7.0)},
                                     {202, member("m202", 1e-4, 2e-4, 7.0)},
                                     {7, demfem::test::scratch("no-metrics")}});
  ASSERT_EQ(e.members.size(), 3U);
  ASSERT_EQ(e.missing.size(), 1U);
  EXPECT_NE(e.missing[0].find("seed 7"), std::string::npos);
  ASSERT_EQ(e.rows.size(), 1U);
  const auto& r = e.rows[0];
  // amplitude: DEM larger in 2, continuum in 1: not decided; statistics over the three
  EXPECT_EQ(r.amplitude.both, 3);
  EXPECT_EQ(r.amplitude.dem_larger, 2);
  EXPECT_EQ(r.amplitude.continuum_larger, 1);
  EXPECT_DOUBLE_EQ(r.amplitude.dem_stat.min, 1e-4);
  EXPECT_DOUBLE_EQ(r.amplitude.dem_stat.median, 3e-4);
  EXPECT_DOUBLE_EQ(r.amplitude.dem_stat.max, 1e-2);
  EXPECT_DOUBLE_EQ(r.amplitude.ratio.max, 50.0);
  EXPECT_NE(r.verdict.find("not decided"), std::string::npos) << r.verdict;
  // static: 1e-5 apart, equal in every realisation (neither larger)
  EXPECT_EQ(r.static_part.dem_larger, 0);
  EXPECT_EQ(r.static_part.continuum_larger, 0);
  EXPECT_NEAR(r.static_part.ratio.min, 1.0, 1e-4); // equal, and still a ratio
  // mean increment: the DEM never measured it: no realisation has both, not in the verdict
  EXPECT_EQ(r.increment.both, 0);
  EXPECT_EQ(r.verdict.find("mean increment"), std::string::npos) << r.verdict;
}

TEST(EnsembleSummary, TheSameSolverLargerEverywhereIsDecided) {
  const auto e =
      summarise_ensemble({{1, member("a1", 3e-4, 2e-4, 0.0)}, {2, member("a2", 1e-2, 2e-4, 0.0)}});
  ASSERT_EQ(e.rows.size(), 1U);
  EXPECT_NE(e.rows[0].verdict.find("the DEM's is larger in every realisation"), std::string::npos)
      << e.rows[0].verdict;
}
