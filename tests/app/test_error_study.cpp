// `demfem study error-vs-time` (issue 11 item 1) end to end: the DEM head-on collision swept in
// Δt, every run its own process; the order fitted by the study must match the theory.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

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
