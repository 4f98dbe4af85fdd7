// Pieces of the error-vs-time study (issue 11 item 1): the log–log fit, the Pareto front and the
// head-on collision's closed form.
#include <cmath>

#include <gtest/gtest.h>

#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/verification.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/studies/error_study.hpp"

using namespace demfem;

TEST(ErrorStudy, LogLogSlopeOfAPowerLaw) {
  std::vector<double> x, y;
  for (double h = 1.0; h > 1e-3; h /= 2) {
    x.push_back(h);
    y.push_back(3.0 * std::pow(h, 1.5));
  }
  EXPECT_NEAR(studies::loglog_slope(x, y), 1.5, 1e-12);
  // zero errors (round-off) are left out; fewer than two usable points give NaN
  EXPECT_TRUE(std::isnan(studies::loglog_slope({1.0, 2.0}, {0.0, 1.0})));
  EXPECT_TRUE(std::isnan(studies::loglog_slope({1.0, 1.0}, {1.0, 2.0})));
}

TEST(ErrorStudy, ParetoFrontKeepsUndominatedPoints) {
  // cost, error: (1, 10) (2, 5) (3, 7) dominated by (2, 5), (4, 1), (5, 1) dominated by (4, 1)
  const auto f = studies::pareto_front({1, 2, 3, 4, 5}, {10, 5, 7, 1, 1});
  EXPECT_EQ(f, (std::vector<std::size_t>{0, 1, 3}));
}

// head_on_collision.toml "fast": m* = ρπr²/2 = 10.406 kg, v_n = 1.6 m/s > V_0: dissipation
// ½ m* v² (1 − K²) = 13.19 J, separation at K v_n = 0.16 m/s, contact π√(m*/K_n) = 10.13 ms.
TEST(ErrorStudy, HeadOnClosedForm) {
  const auto file = scene::load_scene_file(
      DEMFEM_SOURCE_DIR "/cases/verification/head_on_collision.toml", demfem::app::vocabulary());
  const auto c = dem::head_on_closed_form(file.select("fast"));
  ASSERT_TRUE(c);
  EXPECT_NEAR(c->dissipated, 13.19, 0.01);
  EXPECT_NEAR(c->separation, 0.16, 1e-12);
  EXPECT_NEAR(c->contact_time, 10.13e-3, 0.01e-3);
  EXPECT_NEAR(c->touch_time, 0.02 / 1.6, 1e-12);
  const auto b = dem::head_on_closed_form(file.base); // 0.8 m/s < V_0: elastic
  ASSERT_TRUE(b);
  EXPECT_EQ(b->dissipated, 0.0);
  EXPECT_NEAR(b->separation, 0.8, 1e-12);
  std::string why;
  const auto col = scene::load_scene_file(
      DEMFEM_SOURCE_DIR "/cases/verification/two_disk_column.toml", demfem::app::vocabulary());
  EXPECT_FALSE(dem::head_on_closed_form(col.base, &why));
  EXPECT_FALSE(why.empty());
}
