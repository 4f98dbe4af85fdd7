#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "demfem/scene/time_function.hpp"

using demfem::scene::TimeFunction;
constexpr double kPi = std::numbers::pi;

TEST(TimeFunction, Constant) {
  EXPECT_DOUBLE_EQ(TimeFunction::constant(3.5)(123.0), 3.5);
}

TEST(TimeFunction, RampIsZeroBeforeStartThenLinear) {
  const auto f = TimeFunction::ramp(2.0, 1.0, 0.5); // 1 + 2 (t − 0.5)⁺
  EXPECT_DOUBLE_EQ(f(0.0), 1.0);
  EXPECT_DOUBLE_EQ(f(0.5), 1.0);
  EXPECT_DOUBLE_EQ(f(2.0), 1.0 + 2.0 * 1.5);
}

TEST(TimeFunction, RampFreezesAfterStop) {
  auto f = TimeFunction::ramp(1.0);
  f.stop = 3.0;
  EXPECT_DOUBLE_EQ(f(5.0), 3.0);
}

TEST(TimeFunction, SineMatchesFormula) {
  const auto f = TimeFunction::sine(4.0, 3.6, 0.1, 0.0); // A sin(2πft + φ)
  for (double t : {0.0, 0.01, 0.123, 1.7, 24.9})
    EXPECT_NEAR(f(t), 4.0 * std::sin(2 * kPi * 3.6 * t + 0.1), 1e-12);
}

TEST(TimeFunction, SineIsZeroBeforeStartAndAfterStop) {
  auto f = TimeFunction::sine(1.0, 1.0, 0.0, 2.0);
  f.stop = 4.0;
  EXPECT_EQ(f(1.9), 0.0);
  EXPECT_NEAR(f(2.25), 1.0, 1e-12);
  EXPECT_EQ(f(4.1), 0.0);
}

TEST(TimeFunction, TSineIsPaperEquation51) {
  const auto f = TimeFunction::t_sine(5.0e3, kPi); // F = 5e3 · t · sin(πt), case 1-A
  for (double t : {0.0, 0.5, 1.5, 7.25}) EXPECT_NEAR(f(t), 5.0e3 * t * std::sin(kPi * t), 1e-9);
  EXPECT_NEAR(f(1.5), -7.5e3, 1e-9);
}

TEST(TimeFunction, TableInterpolatesAndHolds) {
  const auto f = TimeFunction::piecewise({{0.0, 0.0}, {1.0, 10.0}, {3.0, -10.0}});
  EXPECT_DOUBLE_EQ(f(-1.0), 0.0);
  EXPECT_DOUBLE_EQ(f(0.5), 5.0);
  EXPECT_DOUBLE_EQ(f(2.0), 0.0);
  EXPECT_DOUBLE_EQ(f(2.5), -5.0);
  EXPECT_DOUBLE_EQ(f(9.0), -10.0);
}

TEST(TimeFunction, SumIsLoadTypeB) {
  const auto f = TimeFunction::sum({TimeFunction::ramp(100.0), TimeFunction::sine(50.0, 2.0)});
  for (double t : {0.0, 0.3, 1.1})
    EXPECT_NEAR(f(t), 100.0 * t + 50.0 * std::sin(2 * kPi * 2.0 * t), 1e-9);
}
