// Bad input refused before any work: names that are names, memory estimates against the
// machine's, the particles' container, and the output-size refusal naming the right key.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "demfem/app/vocabulary.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/names.hpp"
#include "demfem/scene/resources.hpp"

using namespace demfem::scene;

namespace {

// A closed 8 m × 5.6 m box of packed disks; line numbers matter (tests below refer to them).
const std::string kBox = R"([scene]
name = "box"
duration = 1.0

[domain]
polygon = [[0, 0], [8, 0], [8, 5.6], [0, 5.6]]

[soil.dem]
count = 100
radius = { uniform = [0.04, 0.075] }

[[wall]]
name = "base"
points = [[0, 0], [8, 0]]

[[wall]]
name = "left"
points = [[0, 5.6], [0, 0]]

[[wall]]
name = "right"
points = [[8, 0], [8, 5.6]]
)";

std::string replaced(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << "test bug: '" << from << "' not in the scene";
  if (pos != std::string::npos) s.replace(pos, from.size(), to);
  return s;
}

std::vector<Diagnostic> errors(const std::string& text) {
  try {
    (void)parse_scene(text, "test.toml", demfem::app::vocabulary());
  } catch (const SceneError& e) {
    return e.diagnostics();
  }
  return {};
}

// The one diagnostic expected, with its line and a piece of its message.
void expect_one(const std::string& text, int line, const std::string& key,
                const std::string& needle) {
  const auto d = errors(text);
  ASSERT_EQ(d.size(), 1u) << (d.empty() ? std::string("accepted") : SceneError(d).what());
  EXPECT_EQ(d[0].line, line) << d[0].format();
  EXPECT_EQ(d[0].key, key) << d[0].format();
  EXPECT_NE(d[0].message.find(needle), std::string::npos) << d[0].format();
}

} // namespace

// ---- names are names -----------------------------------------------------------------------

TEST(Names, SceneAndVariantNamesAreNamesNotPaths) {
  for (const std::string bad : {"../../x", "/abs/path", ".", "..", "a/b", "box 2", "x\\y", "é"})
    EXPECT_TRUE(name_problem(bad)) << bad;
  EXPECT_TRUE(name_problem(std::string("a\0b", 3)));
  EXPECT_TRUE(name_problem(std::string(5000, 'x')));
  EXPECT_TRUE(name_problem(std::string(kMaxNameLength + 1, 'x')));
  EXPECT_TRUE(name_problem(""));
  for (const std::string good : {"box", "case-2", "1-A", "loose_case.12", "...", ".hidden"})
    EXPECT_FALSE(name_problem(good)) << good << ": " << *name_problem(good);
  EXPECT_FALSE(name_problem(std::string(kMaxNameLength, 'x')));
  // shown escaped and cut in messages
  EXPECT_EQ(printable(std::string("a\0b", 3)), "a\\x00b");
  EXPECT_EQ(printable(std::string(50, 'x'), 4), "xxxx…");
}

TEST(Names, RefusedAtTheNamesLine) {
  expect_one(replaced(kBox, "name = \"box\"", "name = \"../../x\""), 2, "scene.name",
             "must be a name, not a path");
  expect_one(replaced(kBox, "name = \"box\"", "name = \"/abs/path\""), 2, "scene.name",
             "holds '/' at character 1");
  expect_one(replaced(kBox, "name = \"box\"", "name = \"..\""), 2, "scene.name",
             "names a directory");
  expect_one(replaced(kBox, "name = \"box\"", "name = \"a\\u0000b\""), 2, "scene.name",
             "holds '\\x00' at character 2");
  expect_one(replaced(kBox, "name = \"box\"", "name = \"" + std::string(5000, 'x') + "\""), 2,
             "scene.name", "has 5000 characters, more than 100");
  // variants: two of them, an absolute name (it escaped --out) and a parent path
  const std::string two = kBox +
                          "\n[[variant]]\nname = \"/abs\"\nset = { \"scene.duration\" = 2 }\n"
                          "\n[[variant]]\nname = \"ok\"\nset = { \"scene.duration\" = 3 }\n";
  expect_one(two, 25, "variant[0].name", "must be a name, not a path");
  expect_one(replaced(two, "\"/abs\"", "\"../../x\""), 25, "variant[0].name",
             "must be a name, not a path");
  // wall and structure names become file names: no separators
  expect_one(replaced(kBox, "name = \"left\"", "name = \"left/../../x\""), 17,
             "wall[left/../../x].name", "holds '/' at character 5");
  EXPECT_TRUE(errors(replaced(kBox, "name = \"left\"", "name = \"left wall\"")).empty());
}

// ---- memory estimates before work ----------------------------------------------------------

// The coarse grid and the dofs the continuum builds for a scene, counted without deal.II: the
// continuum's own log for cases/verification/continuum_footing_load.toml says "2880 cells, 23490
// dofs" at refinement 3 (a 9 × 5 coarse grid through the footing's corners).
TEST(ResourceEstimate, ContinuumMeshAsTheContinuumBuildsIt) {
  auto f = load_scene_file(DEMFEM_SOURCE_DIR "/cases/verification/continuum_footing_load.toml",
                           demfem::app::vocabulary());
  Scene s = f.base;
  s.continuum.refinement = 3;
  auto e = estimate_continuum_mesh(s);
  EXPECT_EQ(e.columns, 9u);
  EXPECT_EQ(e.rows, 5u);
  EXPECT_DOUBLE_EQ(e.cells, 2880.0);
  EXPECT_DOUBLE_EQ(e.dofs, 23490.0);
  s.continuum.refinement = 4;
  e = estimate_continuum_mesh(s);
  EXPECT_DOUBLE_EQ(e.dofs, 93058.0);
  EXPECT_DOUBLE_EQ(e.bytes, kContinuumBaseBytes + 93058.0 * kContinuumBytesPerDof);
  s.continuum.degree = 1;
  EXPECT_DOUBLE_EQ(estimate_continuum_mesh(s).dofs, 2.0 * (9 * 16 + 1) * (5 * 16 + 1));
}

// continuum.refinement = 12 passed the check and reached 6 GB in 47 s before it stopped; now the
// check refuses it at its line with the estimate and the memory it was compared with.
TEST(ResourceEstimate, ContinuumMeshAboveTheAvailableMemoryRefused) {
  const auto avail = available_memory();
  if (!avail) GTEST_SKIP() << "no MemAvailable on this machine";
  EXPECT_GT(avail->bytes, 0.0);
  const std::string cont = R"([scene]
name = "big"
duration = 1.0
solvers = ["continuum"]

[domain]
polygon = [[0, 0], [20, 0], [20, 10], [0, 10]]

[soil.continuum]
model = "elastic"

[continuum]
refinement = 2
)";
  EXPECT_TRUE(errors(cont).empty());
  const auto d = errors(replaced(cont, "refinement = 2", "refinement = 12"));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].line, 13);
  EXPECT_EQ(d[0].key, "continuum.refinement");
  // 8 × 4 coarse cells × 4^12, Q2: 2 (4 · 5.4e8 + 2 · 12 · 4096 + 1) dofs
  EXPECT_NE(d[0].message.find("4.3e+09 degrees of freedom"), std::string::npos) << d[0].message;
  EXPECT_NE(d[0].message.find("available (" + avail->source + ")"), std::string::npos)
      << d[0].message;
}

// ---- the particles' container ---------------------------------------------------------------

TEST(Container, ClosedBoxAccepted) {
  const auto f = parse_scene(kBox, "test.toml", demfem::app::vocabulary());
  EXPECT_TRUE(f.warnings.empty());
  // a side wall taller than the domain: no warning (the open top is open anyway)
  const auto tall =
      parse_scene(replaced(kBox, "points = [[8, 0], [8, 5.6]]", "points = [[8, 0], [8, 7]]"),
                  "test.toml", demfem::app::vocabulary());
  EXPECT_TRUE(tall.warnings.empty()) << tall.warnings.front().format();
}

// A side without a wall: what leaves through it falls out of the scene.
TEST(Container, OpenSideRefused) {
  expect_one(replaced(kBox, "[[wall]]\nname = \"left\"\npoints = [[0, 5.6], [0, 0]]\n", ""), 6,
             "domain.polygon",
             "the side edge [0, 5.6]–[0, 0] of the region the particles fill (the domain polygon) "
             "is not closed");
}

// The base turned down to [8, -3] (a corner moved outside the domain): the bed slides down it and
// off its free end, past the right wall that starts at [8, 0]. A warning for the corner, and an
// error for the lower edge.
TEST(Container, BaseTiltedOutOfTheDomainRefusedAndWarned) {
  const std::string text =
      replaced(kBox, "points = [[0, 0], [8, 0]]", "points = [[0, 0], [8, -3]]");
  const auto d = errors(text);
  ASSERT_EQ(d.size(), 1u) << SceneError(d).what();
  EXPECT_EQ(d[0].key, "domain.polygon");
  EXPECT_NE(d[0].message.find("lower edge [0, 0]–[8, 0]"), std::string::npos) << d[0].message;
  EXPECT_NE(d[0].message.find("slide down wall 'base' and off its end"), std::string::npos)
      << d[0].message;
  // with the right wall reaching down to the base's end the box is closed again (a valley):
  // accepted, with the corner outside the domain a warning at its line
  const auto f =
      parse_scene(replaced(text, "points = [[8, 0], [8, 5.6]]", "points = [[8, -3], [8, 5.6]]"),
                  "test.toml", demfem::app::vocabulary());
  ASSERT_EQ(f.warnings.size(), 2u);
  EXPECT_EQ(f.warnings[0].line, 14);
  EXPECT_EQ(f.warnings[0].key, "wall[base].points[1]");
  EXPECT_NE(f.warnings[0].format().find("test.toml:14:"), std::string::npos);
  EXPECT_NE(f.warnings[0].format().find(": warning: "), std::string::npos);
  EXPECT_NE(f.warnings[0].message.find("corner [8, -3] lies 3 m outside the domain"),
            std::string::npos)
      << f.warnings[0].message;
  EXPECT_EQ(f.warnings[1].key, "wall[right].points[0]");
}

// An open front whose particles land on a wall below (a landslide, cases/slope_ontake.toml) is
// accepted; a fill region floating above the base is held by the base below it.
TEST(Container, OpenEdgesThatLandOnAWallAccepted) {
  const std::string slope = R"([scene]
name = "slope"
duration = 1.0

[domain]
polygon = [[0, 0], [20, 0], [20, 10], [0, 10]]

[soil.dem]
count = 100
radius = { uniform = [0.04, 0.075] }
fill = [[2, 6], [10, 2], [10, 3], [2, 7]]

[[wall]]
name = "ground"
points = [[0, 7], [2, 6], [10, 2], [14, 1], [16, 1]]
)";
  EXPECT_TRUE(errors(slope).empty()) << SceneError(errors(slope)).what();
  // the ground ends at [14, 1], still going down: both open sides slide off into nothing
  const auto d = errors(replaced(slope, ", [16, 1]]", "]"));
  ASSERT_EQ(d.size(), 2u) << SceneError(d).what();
  for (const auto& x : d) {
    EXPECT_EQ(x.line, 11);
    EXPECT_EQ(x.key, "soil.dem.fill");
    EXPECT_NE(x.message.find("slide down wall 'ground' and off its end at [14"), std::string::npos)
        << x.message;
  }
  // floating fill over a walled box
  EXPECT_TRUE(
      errors(replaced(kBox, "radius = { uniform = [0.04, 0.075] }",
                      "radius = { uniform = [0.04, 0.075] }\nfill = [[1, 2], [7, 2], [7, 5], "
                      "[1, 5]]"))
          .empty());
  // explicit particles need no container (verification scenes), nor a continuum-only scene
  EXPECT_TRUE(
      errors(replaced(replaced(kBox, "count = 100", "count = 1\nparticles = [[4, 3, 0.05]]"),
                      "[[wall]]\nname = \"base\"\npoints = [[0, 0], [8, 0]]\n", ""))
          .empty());
}

// ---- the output-size refusal names the key that makes it -----------------------------------

TEST(OutputEstimate, TinyProbeIntervalNamesProbeInterval) {
  expect_one(kBox + "\n[output]\nprobe_interval = 1e-12\n", 25, "output.probe_interval",
             "raise output.probe_interval");
  expect_one(kBox + "\n[output]\ninterval = 1e-9\n", 25, "output.interval",
             "raise output.interval");
}
