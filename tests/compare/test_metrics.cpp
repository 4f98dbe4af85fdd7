// The metric table: one quantity, one name, one row; the static / increment / oscillation split;
// divergence measured on increments.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "../scratch.hpp"

#include "demfem/compare/metric_table.hpp"
#include "demfem/compare/metrics.hpp"
#include "demfem/compare/report.hpp"
#include "demfem/output/contract.hpp"

namespace fs = std::filesystem;
using namespace demfem;

namespace {

// A run directory shaped like the retaining wall's: walls.csv with thrust, reaction_x and
// reaction_z, and structures.csv with the same forces under force_x / force_z, in both solvers.
fs::path wall_run(const std::string& name) {
  const fs::path run = demfem::test::scratch(name);
  for (const char* s : {"dem", "continuum"}) {
    fs::create_directories(run / s);
    const bool dem = std::string(s) == "dem";
    std::ofstream w(run / s / "walls.csv");
    w << "time [s],wall.thrust [N],wall.reaction_x [N],wall.reaction_z [N]\n";
    std::ofstream st(run / s / "structures.csv");
    st << "time [s],wall.settlement [m],wall.rotation [rad],wall.moment [N·m],wall.force_x [N],"
          "wall.force_z [N],wall.applied_moment [N·m],wall.displacement_x [m]\n";
    for (int k = 0; k <= 300; ++k) {
      const double t = 0.01 * k;
      // at rest until 1 s, then a mean rise and an oscillation at 2 Hz
      const double load = t > 1.0 ? 1.0 : 0.0;
      const double thrust =
          (dem ? 200.0 : 100.0) +
          load * ((dem ? 50.0 : 10.0) * (t - 1.0) + 20.0 * std::sin(4 * std::numbers::pi * t));
      const double fz = (dem ? 40.0 : 30.0) + load * 5.0 * (t - 1.0);
      w << fmt::format("{},{},{},{}\n", t, thrust, thrust, fz);
      st << fmt::format("{},0,0,{},{},{},0,0\n", t, 3.0 * thrust, thrust, fz);
    }
  }
  return run;
}

scene::Scene shaken_scene() {
  scene::Scene s;
  scene::Shaking sh;
  sh.acceleration = scene::TimeFunction::sine(1.0, 2.0, 0.0, 1.0);
  s.load.shaking = sh;
  scene::Structure w;
  w.name = "wall";
  w.kind = scene::StructureKind::Wall;
  s.structures.push_back(w);
  return s;
}

} // namespace

// Issue 9: the report listed wall.thrust, wall.force_x and wall.reaction_x (identical), and
// wall.force_z and wall.reaction_z (identical). Each physical quantity must appear once.
TEST(Metrics, NoQuantityTwiceAndNoTwoIdenticalSeries) {
  const auto run = wall_run("demfem_test_metrics_dedup");
  const auto sc = shaken_scene();
  const auto set = compare::collect_metrics(run, &sc);
  ASSERT_FALSE(set.series.empty());
  std::set<std::string> keys, quantities;
  for (const auto& m : set.series) {
    EXPECT_TRUE(keys.insert(m.def.key).second) << "key twice: " << m.def.key;
    EXPECT_TRUE(quantities.insert(m.def.quantity).second) << "quantity twice: " << m.def.quantity;
    EXPECT_FALSE(m.def.dem_source.empty());
    EXPECT_FALSE(m.def.continuum_source.empty());
  }
  for (std::size_t a = 0; a < set.series.size(); ++a)
    for (std::size_t b = a + 1; b < set.series.size(); ++b) {
      EXPECT_NE(set.series[a].dem.y, set.series[b].dem.y)
          << set.series[a].def.key << " and " << set.series[b].def.key << " are identical (DEM)";
      EXPECT_NE(set.series[a].continuum.y, set.series[b].continuum.y)
          << set.series[a].def.key << " and " << set.series[b].def.key
          << " are identical (continuum)";
    }
  // thrust and the vertical force are the two quantities; the moment (3 × thrust here) is a
  // different quantity with its own unit; the others are zero in both and fixed by the scene.
  EXPECT_TRUE(keys.count("wall.thrust"));
  EXPECT_TRUE(keys.count("wall.reaction_z"));
  EXPECT_FALSE(keys.count("wall.force_x"));
  EXPECT_FALSE(keys.count("wall.reaction_x"));
  EXPECT_FALSE(keys.count("wall.force_z"));
  EXPECT_EQ(set.aliases.size(), 3u);
  for (const auto& z : set.zero) EXPECT_NE(z.note.find("fixes"), std::string::npos) << z.def.key;
}

TEST(Metrics, SplitIntoStaticIncrementAndOscillation) {
  // y = 5 at rest (t < 1), then 5 + 2 + 3 sin(2π·2t): static 5, mean increment 2, amplitude 3.
  compare::TimeSeries s;
  for (int k = 0; k <= 1000; ++k) {
    const double t = 0.005 * k;
    s.t.push_back(t);
    s.y.push_back(5.0 + (t > 1.0 ? 2.0 + 3.0 * std::sin(4 * std::numbers::pi * t) : 0.0));
  }
  scene::Scene sc = shaken_scene();
  const auto o = compare::split_options(&sc, 5.0);
  EXPECT_DOUBLE_EQ(o.load_start, 1.0);
  EXPECT_NEAR(o.window, 1.0, 1e-12); // two whole 0.5 s periods
  const auto r = compare::split_series(s, o);
  EXPECT_NEAR(r.static_value, 5.0, 1e-12);
  EXPECT_NEAR(r.mean_increment, 2.0, 0.02);
  EXPECT_NEAR(r.amplitude, 3.0, 0.03);
  // the moving mean removes the oscillation away from the edges
  for (std::size_t i = 0; i < s.t.size(); ++i)
    if (s.t[i] > 1.6 && s.t[i] < 4.4) {
      EXPECT_NEAR(r.mean[i], 2.0, 0.02) << s.t[i];
    }
}

// A static offset alone (the two models at rest differ, their responses do not) is not a
// divergence: divergence is measured on the increments.
TEST(Metrics, StaticOffsetIsNotADivergence) {
  compare::MetricSeries m;
  m.def.key = "x";
  m.def.unit = "N";
  for (int k = 0; k <= 400; ++k) {
    const double t = 0.01 * k;
    const double inc = t > 1.0 ? 10.0 * (t - 1.0) + std::sin(4 * std::numbers::pi * t) : 0.0;
    m.dem.t.push_back(t);
    m.dem.y.push_back(1000.0 + inc);
    if (k % 5 == 0) { // coarser, at rest 40 % lower
      m.continuum.t.push_back(t);
      m.continuum.y.push_back(600.0 + inc);
    }
  }
  scene::Scene sc = shaken_scene();
  const auto o = compare::split_options(&sc, 4.0);
  const auto row = compare::compare_metric(m, o, 0.2);
  EXPECT_NEAR(row.static_part.relative(), -0.4, 1e-9);
  EXPECT_FALSE(row.diverges) << row.verdict;
  EXPECT_LT(row.first_divergence, 0.0);
  EXPECT_NE(row.verdict.find("agree"), std::string::npos);
  // The same pair with half the continuum's increment diverges, after the load starts.
  for (auto& y : m.continuum.y) y = 600.0 + 0.5 * (y - 600.0);
  const auto row2 = compare::compare_metric(m, o, 0.2);
  EXPECT_TRUE(row2.diverges);
  EXPECT_GT(row2.first_divergence, 1.0);
  EXPECT_NEAR(row2.increment.relative(), -0.5, 0.01);
}

// A response that is a sliver of the static value (a footing's weight, its rocking's vertical
// force): the verdict keeps its word and gives the scale.
TEST(Metrics, VerdictGivesTheScaleOfAResponseSmallAgainstTheStaticValue) {
  compare::MetricSeries m;
  m.def.key = "foot.force_z";
  m.def.unit = "N";
  for (int k = 0; k <= 400; ++k) {
    const double t = 0.01 * k;
    const double inc = t > 1.0 ? 100.0 * std::sin(4 * std::numbers::pi * t) : 0.0;
    m.dem.t.push_back(t);
    m.dem.y.push_back(1e6 + inc);
    m.continuum.t.push_back(t);
    m.continuum.y.push_back(1e6 + 0.25 * inc);
  }
  scene::Scene sc = shaken_scene();
  const auto o = compare::split_options(&sc, 4.0);
  const auto row = compare::compare_metric(m, o, 0.2);
  EXPECT_TRUE(row.diverges) << row.verdict; // amplitude 0.25×
  EXPECT_NE(row.verdict.find("in both solvers the response is at most 0.0098 % of the static value "
                             "(1e+06 N)"),
            std::string::npos)
      << row.verdict;
  // A response of 5 % of the static value: no such remark.
  for (std::size_t k = 0; k < m.dem.y.size(); ++k) {
    m.dem.y[k] = 1e6 + 500.0 * (m.dem.y[k] - 1e6);
    m.continuum.y[k] = 1e6 + 500.0 * (m.continuum.y[k] - 1e6);
  }
  const auto row2 = compare::compare_metric(m, o, 0.2);
  EXPECT_EQ(row2.verdict.find("in both solvers the response"), std::string::npos) << row2.verdict;
  // A position's static value is a datum, not a scale: no remark for a surface elevation.
  for (std::size_t k = 0; k < m.dem.y.size(); ++k) {
    m.dem.y[k] = 1e6 + (m.dem.y[k] - 1e6) / 500.0;
    m.continuum.y[k] = 1e6 + (m.continuum.y[k] - 1e6) / 500.0;
  }
  m.def.unit = "m";
  EXPECT_EQ(compare::compare_metric(m, o, 0.2).verdict.find("in both solvers the response"),
            std::string::npos);
}

TEST(Metrics, ReportHasOneRowPerQuantityAndAVerdict) {
  const auto run = wall_run("demfem_test_metrics_report");
  const auto sc = shaken_scene();
  compare::ReportOptions o;
  o.title = "test";
  o.scene = &sc;
  o.fields = false;
  const auto r = compare::write_report(run, o);
  ASSERT_EQ(r.compared.size(), 3u); // thrust, vertical force, soil moment
  EXPECT_EQ(r.compared[0].def.key, "wall.thrust");
  // DEM: static 200, rise 50/s; continuum: static 100, rise 10/s → increments diverge.
  EXPECT_NEAR(r.compared[0].static_part.dem, 200.0, 1e-9);
  EXPECT_NEAR(r.compared[0].static_part.continuum, 100.0, 1e-9);
  EXPECT_TRUE(r.compared[0].diverges);
  EXPECT_GT(r.compared[0].first_divergence, 1.0);
  std::ifstream h(r.html);
  const std::string html((std::istreambuf_iterator<char>(h)), std::istreambuf_iterator<char>());
  EXPECT_NE(html.find("diverge"), std::string::npos);
  EXPECT_EQ(html.find("wall.force_x [N]</td>"), std::string::npos);
}

// A series one solver writes as 0 throughout (nothing measured: e.g. a structure no particle
// touches) is reported as not comparable, not as a divergence.
TEST(Metrics, ZeroInOneSolverIsNotComparable) {
  compare::MetricSeries m;
  m.def.key = "f.moment";
  m.def.unit = "N·m";
  for (int k = 0; k <= 100; ++k) {
    m.dem.t.push_back(0.1 * k);
    m.dem.y.push_back(0.0);
    m.continuum.t.push_back(0.1 * k);
    m.continuum.y.push_back(std::sin(0.1 * k));
  }
  const auto row = compare::compare_metric(m, compare::split_options(nullptr, 10.0), 0.2);
  EXPECT_FALSE(row.comparable);
  EXPECT_FALSE(row.diverges);
  EXPECT_NE(row.verdict.find("not comparable"), std::string::npos);
}

// ---- the metric table -----------------------------------------------------------------------

// Every row is consistent (metric_table.hpp), its key is unique, and the rows one owner gets name
// different quantities.
TEST(MetricTable, KeysAreUniqueAndEachOwnerGetsEachQuantityOnce) {
  using compare::Owners;
  const auto table = compare::metric_table();
  std::set<std::string_view> keys;
  std::map<std::string, std::set<std::string_view>> quantities; // owner kind → quantities
  for (const auto& m : table) {
    EXPECT_TRUE(compare::consistent(m)) << m.key;
    EXPECT_TRUE(keys.insert(m.key).second) << "key twice: " << m.key;
    std::vector<std::string> kinds;
    if (m.owners == Owners::Walls || m.owners == Owners::Structures) kinds.push_back("wall");
    if (m.owners == Owners::Bodies || m.owners == Owners::Structures) kinds.push_back("body");
    if (m.owners == Owners::Scene) kinds.push_back("scene");
    if (m.owners == Owners::PressureTargets) kinds.push_back("pressure target");
    for (const auto& k : kinds)
      EXPECT_TRUE(quantities[k].insert(m.quantity).second) << k << ": " << m.quantity;
  }
  EXPECT_EQ(quantities.size(), 4u);
}

namespace {
// Both solvers' coordination.csv in a run: 4 (DEM) and 3 (continuum) at rest, +0.1 from t = 1 s.
void write_coordination(const fs::path& run) {
  for (const char* s : {"dem", "continuum"}) {
    std::ofstream f(run / s / "coordination.csv");
    f << "time [s],coordination [-]\n";
    for (int k = 0; k <= 300; ++k)
      f << fmt::format("{},{}\n", 0.01 * k, (s[0] == 'd' ? 4.0 : 3.0) + (k > 100 ? 0.1 : 0.0));
  }
}

bool has_series(const compare::MetricSet& set, const std::string& key) {
  return std::any_of(set.series.begin(), set.series.end(),
                     [&](const compare::MetricSeries& m) { return m.def.key == key; });
}
} // namespace

// Adding a metric is adding a row: a table with one more row (the coordination number from both
// solvers' coordination.csv) compares it, records it, lists it in the metric table and draws it;
// the built-in table does not.
TEST(MetricTable, AnExtraRowIsOneMoreComparedMetric) {
  const auto run = wall_run("demfem_test_metrics_extra_row");
  write_coordination(run);
  std::vector<compare::Metric> table(compare::metric_table().begin(),
                                     compare::metric_table().end());
  table.push_back(
      {.key = "coordination",
       .quantity = "coordination number",
       .source = {compare::Read::Column, output::file::coordination, output::col::coordination},
       .unit = "-",
       .meaning = "2 × particle contacts / particles"});
  ASSERT_TRUE(compare::consistent(table.back()));
  const auto sc = shaken_scene();
  EXPECT_FALSE(has_series(compare::collect_metrics(run, &sc), "coordination"));
  const auto set = compare::collect_metrics(run, &sc, table);
  ASSERT_TRUE(has_series(set, "coordination"));

  compare::ReportOptions o;
  o.title = "test";
  o.scene = &sc;
  o.fields = false;
  o.table = table;
  const auto r = compare::write_report(run, o);
  const auto row =
      std::find_if(r.compared.begin(), r.compared.end(),
                   [](const compare::MetricRow& m) { return m.def.key == "coordination"; });
  ASSERT_NE(row, r.compared.end());
  EXPECT_NEAR(row->static_part.dem, 4.0, 1e-9);
  EXPECT_NEAR(row->static_part.continuum, 3.0, 1e-9);
  EXPECT_NEAR(row->increment.relative(), 0.0, 1e-9);
  EXPECT_EQ(compare::outcome_word(*row), "agree") << row->verdict;
  const auto j = nlohmann::json::parse(std::ifstream(r.metrics_json));
  bool recorded = false;
  for (const auto& t : j["metric_table"])
    if (t["key"] == "coordination") {
      recorded = true;
      EXPECT_EQ(t["dem"], "dem/coordination.csv: coordination");
      EXPECT_EQ(t["continuum"], "continuum/coordination.csv: coordination");
    }
  EXPECT_TRUE(recorded);
  std::ifstream h(r.html);
  const std::string html((std::istreambuf_iterator<char>(h)), std::istreambuf_iterator<char>());
  EXPECT_NE(html.find("<td class=\"l\"><code>coordination</code></td>"), std::string::npos);
  EXPECT_NE(html.find("<li><b>coordination number</b>: agree"), std::string::npos);
}

// A check is judged on the same numbers as a verdict, against its own threshold, and says
// "holds" or "fails". The wall's horizontal reaction: the continuum's mean increment is 0.2× the
// DEM's (relative −0.8), the oscillations are equal.
TEST(MetricTable, ACheckHoldsOrFailsAgainstItsOwnThreshold) {
  const auto run = wall_run("demfem_test_metrics_check_row");
  const auto sc = shaken_scene();
  auto word = [&](double threshold) {
    std::vector<compare::Metric> table{
        {.key = "reaction_x",
         .quantity = "horizontal reaction",
         .owners = compare::Owners::Walls,
         .source = {compare::Read::Column, output::file::walls, output::col::reaction_x},
         .unit = "N",
         .threshold = threshold,
         .role = compare::Role::Check}};
    const auto set = compare::collect_metrics(run, &sc, table);
    EXPECT_EQ(set.series.size(), 1u);
    const auto o = compare::split_options(&sc, 3.0);
    const auto row = compare::compare_metric(set.series.at(0), o, 0.2); // 0.2: not the row's
    EXPECT_EQ(row.verdict.rfind(compare::outcome_word(row), 0), 0u) << row.verdict;
    return std::string(compare::outcome_word(row));
  };
  EXPECT_EQ(word(0.5), "fails");
  EXPECT_EQ(word(0.9), "holds");
}
