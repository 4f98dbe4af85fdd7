// docs/quickstart.md's scenes work as the guide says: `demfem check` accepts them, `demfem run`
// runs the first and writes its outputs, `demfem compare` compares the second, and the scene the
// guide prints is the one in docs/examples/.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

#include <gtest/gtest.h>

#include "../scratch.hpp"
#include "demfem/app/vocabulary.hpp"
#include "demfem/scene/load.hpp"

namespace fs = std::filesystem;

namespace {

const fs::path kSource = DEMFEM_SOURCE_DIR;

std::string slurp(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Result {
  int code = -1;
  std::string out; // stdout and stderr
};

// `demfem ARGS` through the shell, from the repository root (as the guide runs it).
Result run_demfem(const std::string& args) {
  const fs::path log = demfem::test::scratch("console.txt");
  const std::string cmd = "cd '" + kSource.string() + "' && '" + DEMFEM_BINARY + "' " + args +
                          " > '" + log.string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(log)};
}

// The last value of the first column of a CSV series (its time), or -1.
double last_time(const fs::path& csv) {
  std::ifstream in(csv);
  double t = -1.0;
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#' && line[0] != 't') t = std::stod(line);
  return t;
}

// A resolved scene without its header comments (they name the source file).
std::string body(const demfem::scene::Scene& s) {
  std::istringstream in(demfem::scene::to_toml(s));
  std::string out;
  for (std::string line; std::getline(in, line);)
    if (line.rfind('#', 0) != 0) out += line + "\n";
  return out;
}

} // namespace

TEST(Quickstart, FirstSceneChecksAndRuns) {
  const auto check = run_demfem("check docs/examples/first_scene.toml");
  EXPECT_EQ(check.code, 0) << check.out;
  EXPECT_NE(check.out.find("OK (1 variant(s): heavy)"), std::string::npos) << check.out;

  const fs::path out = demfem::test::scratch("first-scene");
  const auto run = run_demfem("run docs/examples/first_scene.toml --out '" + out.string() + "'");
  ASSERT_EQ(run.code, 0) << run.out;
  for (const char* f :
       {"scene.resolved.toml", "log.txt", "run_dem.json", "summary.json", "dem/energy.csv",
        "dem/structures.csv", "dem/packing.json", "dem/particles.pvd", "dem/final.ckpt",
        "figures/snapshot_final.png", "figures/footing_settlement.png"})
    EXPECT_TRUE(fs::is_regular_file(out / f)) << f;
  EXPECT_NE(slurp(out / "run_dem.json").find("\"ok\": true"), std::string::npos);
  // The series reach the scene's duration, 0.5 s.
  EXPECT_NEAR(last_time(out / "dem/structures.csv"), 0.5, 0.01);
  EXPECT_NE(slurp(out / "dem/structures.csv").find("footing.settlement [m]"), std::string::npos);
}

#ifdef DEMFEM_TEST_CONTINUUM
TEST(Quickstart, FirstComparisonChecksAndCompares) {
  const auto check = run_demfem("check docs/examples/first_comparison.toml");
  EXPECT_EQ(check.code, 0) << check.out;

  const fs::path out = demfem::test::scratch("first-comparison");
  const auto cmp =
      run_demfem("compare docs/examples/first_comparison.toml --out '" + out.string() + "'");
  ASSERT_EQ(cmp.code, 0) << cmp.out;
  for (const char* f : {"report.html", "metrics.json", "dem/structures.csv",
                        "continuum/structures.csv", "run_continuum.json"})
    EXPECT_TRUE(fs::is_regular_file(out / f)) << f;
  EXPECT_NEAR(last_time(out / "continuum/structures.csv"), 0.5, 0.01);
  EXPECT_NE(slurp(out / "metrics.json").find("footing"), std::string::npos);
}
#endif

// The scene the guide prints (its first ```toml block) is docs/examples/first_scene.toml without
// its variant, and the variant it prints is the file's.
TEST(Quickstart, GuidePrintsTheExampleScene) {
  const std::string guide = slurp(kSource / "docs/quickstart.md");
  const std::regex block("```toml\n([\\s\\S]*?)```");
  std::vector<std::string> blocks;
  for (auto it = std::sregex_iterator(guide.begin(), guide.end(), block);
       it != std::sregex_iterator(); ++it)
    blocks.push_back((*it)[1].str());
  ASSERT_GE(blocks.size(), 2u);
  namespace sc = demfem::scene;
  const auto file =
      sc::load_scene_file(kSource / "docs/examples/first_scene.toml", demfem::app::vocabulary());
  const auto printed =
      sc::parse_scene(blocks[0] + "\n" + blocks[1], "quickstart.md", demfem::app::vocabulary());
  EXPECT_EQ(body(printed.base), body(file.base));
  ASSERT_EQ(printed.variants.size(), 1u);
  ASSERT_EQ(file.variants.size(), 1u);
  EXPECT_EQ(printed.variants[0].variant, file.variants[0].variant);
  EXPECT_EQ(body(printed.variants[0]), body(file.variants[0]));
}
