// Continuum stability classes of `demfem study stability` (issue 11 item 2): each case either
// completes within its closed-form bound or stops (or is refused) with its specific diagnostic.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "demfem/app/vocabulary.hpp"
#include "demfem/continuum/stability.hpp"
#include "demfem/scene/load.hpp"

using namespace demfem::continuum;

namespace {
void print(const StabilityCase& c) {
  std::printf("%s: %s; %s; %s; newton=%d dofs=%zu wall=%.2fs\n", c.name.c_str(), c.outcome.c_str(),
              c.measure.c_str(), c.cause.c_str(), c.newton_iterations, c.dofs, c.wall_seconds);
}
} // namespace

// ν → 0.5: with B-bar the rocking stiffness of a rigid strip stays within 5 % of Gazetas' closed
// form πGB²/(8(1 − ν)) at ν = 0.499; without B-bar the same Q1 mesh locks (stiffer than the B-bar
// run by more than 10 %). Q1 is the element that locks worst; the study runs the scene's degree.
TEST(ContinuumStability, NearIncompressibleLockingWithoutBbar) {
  const auto with = rocking_locking_case(0.499, true, 1);
  const auto without = rocking_locking_case(0.499, false, 1);
  print(with);
  print(without);
  ASSERT_EQ(with.outcome, "completed") << with.cause;
  ASSERT_EQ(without.outcome, "completed") << without.cause;
  EXPECT_NEAR(with.value / with.bound, 1.0, 0.05);
  EXPECT_GT(without.value / with.value, 1.10);
  EXPECT_GT(with.newton_iterations, 0);
  EXPECT_EQ(with.residuals.size(), 1u);
}

// A structure 10⁶× stiffer than the soil: the direct solver carries the contrast (the block's
// rocking stiffness equals that of the same block 10³× stiffer, already rigid in effect, within
// 0.5 %; its own compliance is 10⁻³ of the soil's) and the explicit stable step shrinks by about
// √10⁶ (reported in the measure).
TEST(ContinuumStability, StructureMillionTimesStifferSolves) {
  const auto c = stiff_structure_case(1.0e6, 2);
  print(c);
  ASSERT_EQ(c.outcome, "completed") << c.cause;
  EXPECT_NEAR(c.value / c.bound, 1.0, 0.005);
  EXPECT_NE(c.measure.find("explicit stable step"), std::string::npos);
}

// An explicit continuum step above the stable one is refused before any computation, located at
// continuum.dt, with the stable step in the message.
TEST(ContinuumStability, ExplicitStepAboveCriticalIsRefused) {
  const auto file = demfem::scene::load_scene_file(
      DEMFEM_SOURCE_DIR "/cases/verification/continuum_footing_load.toml",
      demfem::app::vocabulary());
  const auto c = explicit_step_case(file.base, 1.5);
  print(c);
  EXPECT_EQ(c.outcome, "refused");
  EXPECT_NE(c.cause.find("continuum.dt"), std::string::npos) << c.cause;
  EXPECT_NE(c.cause.find("continuum_footing_load.toml"), std::string::npos) << c.cause;
  EXPECT_GT(c.value, c.bound);
}

// ν → 0.5 on a scene's own mesh (issue 11: the stability rows on the scene, not only built-in
// problems): a footing held vertically and embedded 1 m is seated under its weight by the static
// stage; at ν = 0.499 on Q1 cells the run without B-bar locks: the footing sinks less than with
// B-bar. Both runs complete their explicit steps, at a stable step well below the scene's own ν's
// (the P-wave speed grows as ν → 0.5).
TEST(ContinuumStability, SceneNearIncompressibleSeatingLocksWithoutBbar) {
  auto file = demfem::scene::load_scene_file(DEMFEM_SOURCE_DIR
                                             "/cases/verification/continuum_footing_load.toml",
                                             demfem::app::vocabulary());
  auto s = file.base;
  ASSERT_EQ(s.structures.size(), 1u);
  s.structures[0].dof_z = demfem::scene::DofMode::Fixed; // held vertically: seated
  s.continuum.degree = 1;
  const auto with = scene_locking_case(s, 0.499, true);
  const auto without = scene_locking_case(s, 0.499, false);
  print(with);
  print(without);
  ASSERT_EQ(with.outcome, "completed") << with.cause;
  ASSERT_EQ(without.outcome, "completed") << without.cause;
  ASSERT_GT(with.value, 0.0) << with.measure; // the footing's seated settlement [m]
  ASSERT_GT(without.value, 0.0) << without.measure;
  EXPECT_LT(without.value / with.value, 0.9) << "no locking without B-bar";
  EXPECT_NE(with.measure.find("footing seated"), std::string::npos) << with.measure;
  EXPECT_NE(with.measure.find("× the scene's (ν = 0.3)"), std::string::npos) << with.measure;
  EXPECT_GT(with.newton_iterations, 0);
  ASSERT_EQ(with.residuals.size(), 1u);
  EXPECT_LT(with.residuals[0], 1e-6);
  EXPECT_GT(with.load_steps, 0);
  EXPECT_GT(with.bound, 0.0);
}

// A load near the Prandtl limit (2 + π)c: at 0.9 × the run completes every load step.
TEST(ContinuumStability, LoadNearPrandtlLimitCompletes) {
  const auto near = bearing_capacity_case(0.9, 2);
  print(near);
  EXPECT_EQ(near.outcome, "completed") << near.cause;
  EXPECT_NEAR(near.value, 0.9, 1e-12);
  EXPECT_EQ(near.residuals.size(), 10u);
}

// Beyond the limit, at 1.1 × (2 + π)c, Newton finds no equilibrium and the run stops, saying at
// which load, after completing the load steps up to at least 0.9 × (the FE collapse load of this
// mesh is within 5 % of (2 + π)c).
TEST(ContinuumStability, LoadBeyondPrandtlLimitStopsWithNoEquilibrium) {
  const auto beyond = bearing_capacity_case(1.1, 2);
  print(beyond);
  EXPECT_EQ(beyond.outcome, "stopped");
  EXPECT_NE(beyond.cause.find("no equilibrium"), std::string::npos) << beyond.cause;
  EXPECT_GE(beyond.value, 0.9);
  EXPECT_LT(beyond.value, 1.1);
}
