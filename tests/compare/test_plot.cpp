#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "../scratch.hpp"

#include "demfem/compare/plot.hpp"
#include "demfem/scene/write_file.hpp"

namespace fs = std::filesystem;
using namespace demfem;

namespace {
fs::path tmpdir(const std::string& name) {
  return demfem::test::scratch_dir(name);
}
bool is_png(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  char sig[8] = {};
  in.read(sig, 8);
  return in && sig[1] == 'P' && sig[2] == 'N' && sig[3] == 'G';
}
} // namespace

TEST(Csv, ReadsHeaderUnitsAndRows) {
  const auto d = tmpdir("csv");
  std::ofstream(d / "a.csv") << "# demfem\ntime [s],wall.thrust [N]\n0,1.5\n0.5,2.5\n";
  const auto t = compare::read_csv(d / "a.csv");
  ASSERT_EQ(t.columns.size(), 2u);
  EXPECT_EQ(t.find("wall.thrust"), 1);
  EXPECT_EQ(t.find("thrust"), -1);
  EXPECT_EQ(t.column("time"), (std::vector<double>{0.0, 0.5}));
  EXPECT_EQ(t.column("wall.thrust [N]"), (std::vector<double>{1.5, 2.5}));
}

TEST(RunningMean, IsCentredAndExactOnLinearData) {
  std::vector<double> y;
  for (int i = 0; i < 20; ++i) y.push_back(2.0 * i);
  const auto m = compare::running_mean(y, 5);
  for (int i = 2; i < 18; ++i) EXPECT_DOUBLE_EQ(m[i], y[i]); // mean of a line over a centred window
  EXPECT_DOUBLE_EQ(m[0], (0.0 + 2.0 + 4.0) / 3.0);           // clipped at the start
}

TEST(RunningMean, RemovesAPeriodicPart) {
  std::vector<double> y;
  for (int i = 0; i < 400; ++i) y.push_back(10.0 + ((i % 10) < 5 ? 1.0 : -1.0));
  const auto m = compare::running_mean(y, 21); // ~2 periods
  for (int i = 50; i < 350; ++i) EXPECT_NEAR(m[i], 10.0, 0.1);
}

TEST(Plot, WritesPngSvgAndScript) {
  const auto d = tmpdir("plot");
  compare::PlotSpec s;
  s.title = "wall force";
  s.xlabel = "t [s]";
  s.ylabel = "F [N]";
  s.series.push_back({"thrust", {0, 1, 2}, {1, 3, 2}, "linespoints", ""});
  std::string err;
  ASSERT_TRUE(compare::plot(s, d / "f.png", &err)) << err;
  EXPECT_TRUE(is_png(d / "f.png"));
  EXPECT_TRUE(fs::exists(d / "f.svg"));
  EXPECT_TRUE(fs::exists(d / "f.gp"));
}

// A figure whose gnuplot input cannot be written (here its data file's name is taken by a
// directory) is a WriteError naming that file and the cause, not a figure drawn from a partial
// or missing input (issue 13).
TEST(Plot, UnwritableInputIsAClearError) {
  const auto d = tmpdir("plot_unwritable");
  fs::create_directories(d / "f.dat");
  compare::PlotSpec s;
  s.series.push_back({"thrust", {0, 1, 2}, {1, 3, 2}, "lines", ""});
  std::string err, message;
  try {
    (void)compare::plot(s, d / "f.png", &err);
    ADD_FAILURE() << "no error; err = " << err;
  } catch (const scene::WriteError& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("cannot write " + (d / "f.dat").string() + ": Is a directory"),
            std::string::npos)
      << message;
  EXPECT_FALSE(fs::exists(d / "f.png"));
  EXPECT_FALSE(fs::exists(d / "f.gp"));
  EXPECT_FALSE(fs::exists(d / "f.dat.tmp"));
}

TEST(Plot, ParticleSnapshotWithChains) {
  const auto d = tmpdir("snap");
  dem::Particles p;
  for (int i = 0; i < 3; ++i) {
    p.x.push_back(i * 0.2);
    p.z.push_back(0.1);
    p.vx.push_back(0.1 * i);
    p.vz.push_back(0.0);
    p.radius.push_back(0.1);
    p.flags.push_back(0);
  }
  std::vector<dem::ContactView> c{{0, 1, 0.1, 0.1, 5.0, 1.0, false},
                                  {1, 2, 0.3, 0.1, -2.0, 0.0, true}};
  std::vector<dem::BoundaryView> b{{"base", {-0.2, 0.6}, {0.0, 0.0}, false, false}};
  std::string err;
  ASSERT_TRUE(compare::plot_particles(p, c, b, {"three disks", true, 4.0}, d / "s.png", &err))
      << err;
  EXPECT_TRUE(is_png(d / "s.png"));
}
