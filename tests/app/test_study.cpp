// `demfem study stability`: the DEM rows of the stability matrix on the two-disk
// column; the rows at 0.9 and 1.1 × the stable limit verify the time-step guard.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "cli_util.hpp"

#include "../scratch.hpp"

namespace fs = std::filesystem;

namespace {
using demfem::test::slurp;
// The "outcome" of the row named `name` in study.json.
std::string outcome(const std::string& json, const std::string& name) {
  const auto k = json.find("\"name\": \"" + name + "\"");
  if (k == std::string::npos) return "(no row)";
  const auto o = json.find("\"outcome\": \"", k);
  const auto b = o + 12;
  return json.substr(b, json.find('"', b) - b);
}
} // namespace

TEST(StudyStability, TwoDiskColumnRowsAndTables) {
  const fs::path out = demfem::test::scratch("study");
  const std::string cmd = std::string(DEMFEM_BINARY) +
                          " study stability " DEMFEM_SOURCE_DIR
                          "/cases/verification/two_disk_column.toml --duration 0.3 --out " +
                          out.string() + " > " + (out.string() + ".log") + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(out.string() + ".log");
  const auto json = slurp(out / "study.json");
  EXPECT_EQ(outcome(json, "base"), "completed") << json;
  EXPECT_EQ(outcome(json, "dt-0.9"), "completed") << json;
  EXPECT_EQ(outcome(json, "dt-1.1"), "refused") << json;
  EXPECT_EQ(outcome(json, "dt-2"), "refused") << json;
  EXPECT_EQ(outcome(json, "kn-x1000"), "completed") << json;
  EXPECT_EQ(outcome(json, "radius-ratio-10"), "not applicable") << json;
  EXPECT_NE(slurp(out / "study.md").find("| dt-1.1 |"), std::string::npos);
  EXPECT_NE(slurp(out / "study.html").find("<table>"), std::string::npos);
}

// The two-disk column has no closed form and nothing of the metric table to measure (no
// structure, no surface profile): error-vs-time refuses it (exit 2).
TEST(StudyStability, ErrorVsTimeRefusesSceneWithNothingToMeasure) {
  const std::string cmd = std::string(DEMFEM_BINARY) +
                          " study error-vs-time " DEMFEM_SOURCE_DIR
                          "/cases/verification/two_disk_column.toml > /dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 2);
}
