// Estimates and limits before work, end to end: --threads capped at the usable cores, seeds
// range-checked before anything is written, scene warnings printed, and `check` refusing a mesh
// above the available memory with the number it compared with.
#include <filesystem>
#include <sched.h>
#include <string>

#include <gtest/gtest.h>

#include "cli_util.hpp"

namespace fs = std::filesystem;

using demfem::test::run;
using demfem::test::slurp;
using demfem::test::write_temp;

namespace {

const std::string kCollision =
    std::string(DEMFEM_SOURCE_DIR) + "/cases/verification/head_on_collision.toml";

int cores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  return sched_getaffinity(0, sizeof(set), &set) == 0 ? CPU_COUNT(&set) : 1;
}

} // namespace

// --threads 100000 was taken as asked; now it is warned about and the run uses (and records) the
// usable cores.
TEST(GuardRails, ThreadsAboveTheCoresWarnedAndCapped) {
  const fs::path out = demfem::test::scratch("threads");
  const auto r = run("run " + kCollision + " --threads 100000 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("--threads 100000 is more than the " + std::to_string(cores()) +
                       " core(s) this process may use"),
            std::string::npos)
      << r.out;
  EXPECT_NE(slurp(out / "run_dem.json").find("\"threads\": " + std::to_string(cores()) + ","),
            std::string::npos)
      << slurp(out / "run_dem.json");
}

// --seeds 99999999999999999999 saturated to INT64_MAX and wrote a resolved scene that failed
// `check`; seeds are now checked against scene.seed's range before anything is written.
TEST(GuardRails, SeedsOutOfRangeRefusedBeforeAnythingIsWritten) {
  const fs::path out = demfem::test::scratch("seeds");
  auto r = run("compare " + kCollision + " --seeds 99999999999999999999 --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("not in range 0 to 2147483647"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));
  r = run("compare " + kCollision + " --seeds 4,2147483648 --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  r = run("run " + kCollision + " --seed 2147483648 --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_FALSE(fs::exists(out));
}

// A wall corner outside the domain: `check` accepts the scene and prints the warning at its line.
TEST(GuardRails, CheckPrintsSceneWarnings) {
  const auto scene = write_temp("corner.toml", R"([scene]
name = "corner"
duration = 0.1

[domain]
polygon = [[0, 0], [8, 0], [8, 5.6], [0, 5.6]]

[soil.dem]
count = 100
radius = { uniform = [0.04, 0.075] }

[[wall]]
name = "base"
points = [[-1, 0], [9, 0]]

[[wall]]
name = "left"
points = [[0, 5.6], [0, 0]]

[[wall]]
name = "right"
points = [[8, 0], [8, 5.6]]
)");
  const auto r = run("check -q " + scene.string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find(scene.string() + ":14:11: warning: wall[base].points[0]: corner [-1, 0] "
                                        "lies 1 m outside the domain"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("wall[base].points[1]"), std::string::npos) << r.out;
}

// continuum.refinement = 12 passed `check` and reached 6 GB in 47 s; now `check` refuses it with
// the estimate and the available memory it used (exit 2).
TEST(GuardRails, CheckRefusesAMeshAboveTheAvailableMemory) {
  const auto r = run("check " + std::string(DEMFEM_SOURCE_DIR) +
                     "/tests/malformed/continuum_refinement_12.toml");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("degrees of freedom) needs about"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("available (MemAvailable in /proc/meminfo)"), std::string::npos) << r.out;
}
