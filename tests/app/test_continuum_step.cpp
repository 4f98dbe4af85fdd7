// An explicit-integrator continuum.dt above the stable step is refused by `demfem
// check` and by `demfem run --solver continuum` alike: exit 2, the same file:line:col of the dt key
// (or of the variant's override) and the same message.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "cli_util.hpp"

#ifdef DEMFEM_TEST_CONTINUUM
namespace fs = std::filesystem;

using demfem::test::Result;
using demfem::test::run;
using demfem::test::write_temp;

namespace {

// An elastic column (1 m × 10 m, 0.125 m Q2 cells at refinement 1, c_p ≈ 154 m/s); `dt` is on
// line 18, the variant's override on line 26.
std::string column(const std::string& dt, const std::string& variant_dt) {
  return "[scene]\n"                                      // 1
         "name = \"explicit-step\"\n"                     // 2
         "solvers = [\"continuum\"]\n"                    // 3
         "duration = 0.002\n"                             // 4
         "[domain]\n"                                     // 5
         "polygon = [[0, 0], [1, 0], [1, 10], [0, 10]]\n" // 6
         "[soil.continuum]\n"                             // 7
         "model = \"elastic\"\n"                          // 8
         "young = 3.0e7\n"                                // 9
         "poisson = 0.3\n"                                // 10
         "density = 1700\n"                               // 11
         "k0 = 0.428571428571\n"                          // 12
         "[continuum]\n"                                  // 13
         "refinement = 1\n"                               // 14
         "degree = 2\n"                                   // 15
         "integrator = \"explicit\"\n"                    // 16
         "linear_solver = \"direct\"\n"                   // 17
         "dt = " +
         dt +
         "\n"                       // 18
         "[load]\n"                 // 19
         "gravity = 9.81\n"         // 20
         "[output]\n"               // 21
         "vtk = false\n"            // 22
         "probe_interval = 0.001\n" // 23
         "[[variant]]\n"            // 24
         "name = \"v\"\n"           // 25
         "set = { \"continuum.dt\" = " +
         variant_dt + " }\n"; // 26
}

// The first "…: error: continuum.dt: …" line of an output.
std::string dt_error(const std::string& out) {
  const auto k = out.find(": error: continuum.dt: ");
  if (k == std::string::npos) return "";
  const auto b = out.rfind('\n', k);
  const auto e = out.find('\n', k);
  return out.substr(b == std::string::npos ? 0 : b + 1, (e == std::string::npos ? out.size() : e) -
                                                            (b == std::string::npos ? 0 : b + 1));
}

// The stable step a refusal names ("… stable step X s …").
double stable_in(const std::string& line) {
  const std::string tag = "stable step ";
  const auto k = line.find(tag);
  return k == std::string::npos ? 0.0 : std::stod(line.substr(k + tag.size()));
}

} // namespace

TEST(ContinuumStep, CheckAndRunRefuseAnExplicitStepAboveTheStableStepAtTheDtKey) {
  const fs::path p = write_temp("explicit_step.toml", column("1.0", "0.5"));
  const Result c = run("check " + p.string());
  EXPECT_EQ(c.code, 2) << c.out;
  const std::string base = dt_error(c.out);
  ASSERT_NE(base.find("explicit_step.toml:18:"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("explicit_step.toml:26:"), std::string::npos) << c.out; // the variant's
  const double stable = stable_in(base);
  // c_p = √((λ + 2G)/ρ) ≈ 154 m/s, h = 0.125 m: a Q2 cell's critical step is a fraction of h/c_p
  EXPECT_GT(stable, 0.05 * 0.125 / 154.0) << base;
  EXPECT_LT(stable, 0.8 * 0.125 / 154.0) << base;

  const fs::path out = demfem::test::scratch("explicit_step_run");
  const Result r = run("run " + p.string() + " --solver continuum --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_EQ(dt_error(r.out), base) << r.out;
  EXPECT_FALSE(fs::exists(out / "continuum" / "structures.csv"));
}

TEST(ContinuumStep, AStepBelowTheLimitRunsAndARefinedRunRefusesItAtTheSameKey) {
  // the limit at refinement 1, from the refusal of a step far above it
  const fs::path probe = write_temp("explicit_probe.toml", column("1.0", "1.0"));
  const double stable = stable_in(dt_error(run("check " + probe.string()).out));
  ASSERT_GT(stable, 0.0);
  const std::string ok = std::to_string(0.9 * stable);
  const fs::path p = write_temp("explicit_ok.toml", column(ok, ok));
  const Result c = run("check " + p.string());
  EXPECT_EQ(c.code, 0) << c.out;
  const fs::path out = demfem::test::scratch("explicit_ok_run");
  const Result r = run("run " + p.string() + " --solver continuum --out " + out.string());
  EXPECT_EQ(r.code, 0) << r.out;
  // refinement 2 halves the cells and the stable step: the run refuses 0.9 × the refinement-1
  // limit at the dt key, with the refined mesh's limit
  const fs::path out2 = demfem::test::scratch("explicit_fine_run");
  const Result f =
      run("run " + p.string() + " --solver continuum --refinement 2 --out " + out2.string());
  EXPECT_EQ(f.code, 2) << f.out;
  const std::string line = dt_error(f.out);
  EXPECT_NE(line.find("explicit_ok.toml:18:"), std::string::npos) << f.out;
  EXPECT_NE(line.find("refinement-2"), std::string::npos) << f.out;
  EXPECT_NEAR(stable_in(line), 0.5 * stable, 0.05 * stable) << line;
}
// The continuum solver is a module the program opens at its first continuum call
// (continuum/module.hpp): a DEM-only run loads neither the module nor deal.II (the dynamic
// loader's own record, LD_DEBUG=files, lists every object it opens), a continuum run loads both,
// and a module that cannot be opened fails the run (exit 1) with the path and the reason.
TEST(ContinuumModule, DemRunLoadsNoDealIIAndAContinuumRunLoadsTheModule) {
  const fs::path dem_out = demfem::test::scratch("module_dem_run");
  const Result d = demfem::test::run_raw(
      "LD_DEBUG=files " + std::string(DEMFEM_BINARY) + " run " + DEMFEM_SOURCE_DIR +
      "/cases/verification/head_on_collision.toml --out " + dem_out.string());
  EXPECT_EQ(d.code, 0) << d.out.substr(0, 4000);
  EXPECT_NE(d.out.find("file=libfmt"), std::string::npos) << d.out.substr(0, 4000); // recorded
  EXPECT_EQ(d.out.find("libdeal"), std::string::npos);
  EXPECT_EQ(d.out.find("libpetsc"), std::string::npos);
  EXPECT_EQ(d.out.find("libdemfem-continuum"), std::string::npos);

  const fs::path p = write_temp("module_column.toml", column("0.0", "0.0"));
  const fs::path out = demfem::test::scratch("module_continuum_run");
  const Result c = demfem::test::run_raw("LD_DEBUG=files " + std::string(DEMFEM_BINARY) + " run " +
                                         p.string() + " --solver continuum --out " + out.string());
  EXPECT_EQ(c.code, 0) << c.out.substr(0, 4000);
  EXPECT_NE(c.out.find("libdemfem-continuum.so"), std::string::npos);
  EXPECT_NE(c.out.find("libdeal"), std::string::npos);
}

TEST(ContinuumModule, AModuleThatCannotBeOpenedFailsTheRunNamingIt) {
  const fs::path p = write_temp("module_missing.toml", column("0.0", "0.0"));
  const fs::path out = demfem::test::scratch("module_missing_run");
  const Result r = demfem::test::run_raw(
      "DEMFEM_CONTINUUM_MODULE=/nonexistent/libdemfem-continuum.so " + std::string(DEMFEM_BINARY) +
      " run " + p.string() + " --solver continuum --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("continuum solver module (libdemfem-continuum.so) could not be loaded"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("/nonexistent/libdemfem-continuum.so: cannot open shared object file"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("DEMFEM_CONTINUUM_MODULE"), std::string::npos) << r.out;
}
#endif
