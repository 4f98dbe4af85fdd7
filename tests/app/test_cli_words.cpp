// The words of the command line demfem does not know: an unknown subcommand or option is named,
// with the nearest valid word (exit 2); `demfem help` and `demfem help COMMAND`.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "cli_util.hpp"

namespace fs = std::filesystem;

using demfem::test::run;

namespace {

const std::string kScene = (fs::path(DEMFEM_SOURCE_DIR) / "cases/retaining_wall.toml").string();

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

} // namespace

TEST(CliWords, UnknownCommandSuggestsTheNearest) {
  const auto r = run("rnu");
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(has(r.out, "demfem: 'rnu' is not a demfem command; did you mean 'run'?")) << r.out;
  const auto c = run("comapre " + kScene);
  EXPECT_EQ(c.code, 2);
  EXPECT_TRUE(has(c.out, "did you mean 'compare'?")) << c.out;
  const auto p = run("calib " + kScene); // the one command it begins
  EXPECT_EQ(p.code, 2);
  EXPECT_TRUE(has(p.out, "did you mean 'calibrate'?")) << p.out;
}

TEST(CliWords, UnknownCommandFarFromEveryOneSuggestsNone) {
  const auto r = run("frobnicate");
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(has(r.out, "'frobnicate' is not a demfem command")) << r.out;
  EXPECT_FALSE(has(r.out, "did you mean")) << r.out;
  EXPECT_TRUE(has(r.out, "demfem help")) << r.out;
  // the hidden command is not offered
  EXPECT_FALSE(has(run("study-pint").out, "'study-point'"));
}

TEST(CliWords, UnknownOptionSuggestsTheNearest) {
  const auto r = run("run " + kScene + " --sovler dem");
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(has(r.out, "demfem run: unknown option '--sovler'; did you mean '--solver'?"))
      << r.out;
  EXPECT_FALSE(has(r.out, "File does not exist")) << r.out;
  const auto t = run("study stability " + kScene + " --thread 2");
  EXPECT_EQ(t.code, 2);
  EXPECT_TRUE(has(t.out, "unknown option '--thread'; did you mean '--threads'?")) << t.out;
  const auto e = run("compare " + kScene + " --out=x --sedes 1,2");
  EXPECT_EQ(e.code, 2);
  EXPECT_TRUE(has(e.out, "unknown option '--sedes'; did you mean '--seeds'?")) << e.out;
}

TEST(CliWords, AnOptionOfAnotherCommandIsUnknownHere) {
  const auto r = run("check --solver dem " + kScene);
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(has(r.out, "demfem check: unknown option '--solver' (see 'demfem help check')"))
      << r.out;
  const auto b = run("check --bogus x.toml");
  EXPECT_EQ(b.code, 2);
  EXPECT_TRUE(has(b.out, "unknown option '--bogus'")) << b.out;
  const auto v = run("--verison");
  EXPECT_EQ(v.code, 2);
  EXPECT_TRUE(has(v.out, "demfem: unknown option '--verison'; did you mean '--version'?")) << v.out;
}

TEST(CliWords, NegativeNumbersAndJoinedValuesAreNotOptions) {
  const auto n = run("run " + kScene + " --seed -1");
  EXPECT_EQ(n.code, 2); // --seed takes a non-negative number: the parser says so
  EXPECT_FALSE(has(n.out, "unknown option")) << n.out;
  const auto j =
      run("run " + kScene + " --solver=lattice --out " + demfem::test::scratch("x").string());
  EXPECT_EQ(j.code, 2);
  EXPECT_TRUE(has(j.out, "unknown solver 'lattice'")) << j.out;
}

TEST(CliWords, HelpListsTheCommandsAndEachOnesOptions) {
  const auto all = run("help");
  EXPECT_EQ(all.code, 0) << all.out;
  for (const char* s :
       {"run", "check", "compare", "study", "calibrate", "pack", "help", "Exit codes"})
    EXPECT_TRUE(has(all.out, s)) << s << "\n" << all.out;
  EXPECT_FALSE(has(all.out, "study-point")) << all.out;
  EXPECT_EQ(all.out, run("--help").out);
  for (const char* c : {"run", "check", "compare", "study", "calibrate", "pack"}) {
    const auto h = run(std::string("help ") + c);
    EXPECT_EQ(h.code, 0) << c;
    EXPECT_EQ(h.out, run(std::string(c) + " --help").out) << c;
  }
  EXPECT_TRUE(has(run("help run").out, "--solver"));
  const auto u = run("help rnu");
  EXPECT_EQ(u.code, 2);
  EXPECT_TRUE(has(u.out, "'rnu' is not a demfem command; did you mean 'run'?")) << u.out;
}
