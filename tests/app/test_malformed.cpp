// The malformed-input suite (issue 13): every scene under tests/malformed/ must be refused by
// `demfem run` with exit 2, a diagnostic located at the line marked "# ERROR" in the file, the
// message named on its first line ("# expect: …"), and no run directory created. Particle files
// the scenes name lie in tests/malformed/data; a problem in one is located at the line of the
// scene's particles_file key (and in the file).
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>

#include "cli_util.hpp"

namespace fs = std::filesystem;

namespace {

using demfem::test::Result;
Result run_demfem(const std::string& args) {
  return demfem::test::run(args);
}

std::vector<std::string> malformed_cases() {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(fs::path(DEMFEM_SOURCE_DIR) / "tests/malformed"))
    if (e.path().extension() == ".toml") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

class Malformed : public ::testing::TestWithParam<std::string> {};

TEST_P(Malformed, RefusedWithLocationAndNoRunDirectory) {
  const fs::path scene = fs::path(DEMFEM_SOURCE_DIR) / "tests/malformed" / (GetParam() + ".toml");
  std::ifstream in(scene);
  ASSERT_TRUE(in) << scene;
  std::string line, expect;
  int n = 0, error_line = 0;
  while (std::getline(in, line)) {
    ++n;
    if (n == 1 && line.rfind("# expect: ", 0) == 0) expect = line.substr(10);
    if (line.find("# ERROR") != std::string::npos) error_line = n;
  }
  ASSERT_FALSE(expect.empty()) << "first line must be '# expect: <message>'";
  ASSERT_GT(error_line, 0) << "one line must carry the marker '# ERROR'";
  const fs::path out = demfem::test::scratch("out");
  const auto r = run_demfem("run " + scene.string() + " --all-variants --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  const std::string where = scene.string() + ":" + std::to_string(error_line) + ":";
  EXPECT_NE(r.out.find(where), std::string::npos) << "expected " << where << " in\n" << r.out;
  EXPECT_NE(r.out.find(expect), std::string::npos) << "expected '" << expect << "' in\n" << r.out;
  EXPECT_EQ(r.out.find("stoul"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out)) << "a run directory was created for a refused scene";
  fs::remove_all(out);
  // `check` refuses it the same way.
  const auto c = run_demfem("check -q " + scene.string());
  EXPECT_EQ(c.code, 2) << c.out;
  EXPECT_NE(c.out.find(where), std::string::npos) << c.out;
}

INSTANTIATE_TEST_SUITE_P(Scenes, Malformed, ::testing::ValuesIn(malformed_cases()),
                         [](const auto& param_info) { return param_info.param; });

TEST(MalformedSuite, HasAtLeastEightyCases) {
  EXPECT_GE(malformed_cases().size(), 80u);
}

} // namespace
