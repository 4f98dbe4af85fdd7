#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "demfem/compare/report.hpp"

namespace fs = std::filesystem;
using namespace demfem;

TEST(Report, InterpolateIsLinearAndHeld) {
  const std::vector<double> t{0, 1, 3}, y{0, 2, 6};
  EXPECT_DOUBLE_EQ(compare::interpolate(t, y, 0.5), 1.0);
  EXPECT_DOUBLE_EQ(compare::interpolate(t, y, 2.0), 4.0);
  EXPECT_DOUBLE_EQ(compare::interpolate(t, y, -1.0), 0.0);
  EXPECT_DOUBLE_EQ(compare::interpolate(t, y, 9.0), 6.0);
}

TEST(Report, ComparesSeriesWithTheSameNameAcrossSolvers) {
  const fs::path run = fs::temp_directory_path() / "demfem_test_report";
  fs::remove_all(run);
  fs::create_directories(run / "dem");
  fs::create_directories(run / "continuum");
  {
    // DEM: thrust = 100 for t < 1, then 200; continuum: 100 throughout, on a coarser time base.
    std::ofstream d(run / "dem" / "wall.csv");
    d << "time [s],wall.thrust [N],wall.only_dem [N]\n";
    for (int k = 0; k <= 200; ++k) d << k * 0.01 << "," << (k * 0.01 < 1.0 ? 100 : 200) << ",1\n";
    std::ofstream c(run / "continuum" / "probes.csv");
    c << "time [s],wall.thrust [N]\n";
    for (int k = 0; k <= 20; ++k) c << k * 0.1 << ",100\n";
    // A pressure profile (two bins) and a quantity that is zero in both: the profile is compared as
    // a profile, the zero pair is left out.
    std::ofstream dp(run / "dem" / "pressure_wall.csv");
    dp << "time [s],wall.bin0 [Pa],wall.bin1 [Pa],wall.rotation [rad]\n0,10,5,0\n1,30,15,0\n";
    std::ofstream cp(run / "continuum" / "pressure_wall.csv");
    cp << "time [s],wall.bin0 [Pa],wall.bin1 [Pa],wall.rotation [rad]\n0,20,10,0\n1,20,10,0\n";
  }
  compare::ReportOptions o;
  o.title = "test";
  o.divergence_threshold = 0.1;
  const auto r = compare::write_report(run, o);
  ASSERT_EQ(r.compared.size(), 1u);
  const auto& m = r.compared[0];
  EXPECT_EQ(m.name, "wall.thrust [N]");
  EXPECT_DOUBLE_EQ(m.max_abs_dem, 200.0);
  EXPECT_NEAR(m.first_divergence_time, 1.0, 1e-9); // the step
  EXPECT_NEAR(m.rms_difference, 100.0 * std::sqrt(101.0 / 201.0),
              1e-6);                         // 101 of 201 samples differ by 100
  EXPECT_NEAR(m.late_mean_dem, 200.0, 1e-9); // last third of [0, 2] s is all after the step
  EXPECT_NEAR(m.late_mean_continuum, 100.0, 1e-9);
  EXPECT_TRUE(fs::exists(r.html));
  ASSERT_EQ(r.profile_figures.size(), 1u);
  const auto j = nlohmann::json::parse(std::ifstream(r.metrics_json));
  EXPECT_EQ(j["series"].size(), 1u);
  const auto& prof = j["pressure_profiles"]["wall"];
  ASSERT_EQ(prof.size(), 2u);
  EXPECT_NEAR(prof[0]["dem_Pa"].get<double>(), 20.0, 1e-9); // time mean of 10 and 30
  EXPECT_NEAR(prof[0]["continuum_Pa"].get<double>(), 20.0, 1e-9);
  EXPECT_NEAR(prof[1]["height_fraction"].get<double>(), 0.75, 1e-12);
  std::ifstream h(r.html);
  const std::string html((std::istreambuf_iterator<char>(h)), std::istreambuf_iterator<char>());
  EXPECT_NE(html.find("wall.thrust [N]"), std::string::npos);
  EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos);
}
