#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>
#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGReader.h>
#include <vtkPointData.h>

#include "../scratch.hpp"

#include "demfem/compare/figures.hpp"
#include "demfem/compare/gnuplot_run.hpp"
#include "demfem/compare/plot.hpp"
#include "demfem/compare/raster.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/dem/state.hpp"
#include "demfem/scene/write_file.hpp"

namespace fs = std::filesystem;
using namespace demfem;

namespace {
fs::path tmpdir(const std::string& name) {
  return demfem::test::scratch_dir(name);
}
std::vector<unsigned char> png_pixels(const fs::path& p); // RGB(A) bytes read back through VTK
// n disks of radius 0.1 m in a row at z = 0.1 m, 0.2 m apart, disk i moving at vx = i·vx_step.
dem::Particles disk_row(int n, double vx_step) {
  dem::Particles p;
  for (int i = 0; i < n; ++i) {
    p.x.push_back(i * 0.2);
    p.z.push_back(0.1);
    p.vx.push_back(vx_step * i);
    p.vz.push_back(0.0);
    p.radius.push_back(0.1);
    p.flags.push_back(0);
  }
  return p;
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
  const dem::Particles p = disk_row(3, 0.1);
  std::vector<dem::ContactView> c{{0, 1, 0.1, 0.1, 5.0, 1.0, false},
                                  {1, 2, 0.3, 0.1, -2.0, 0.0, true}};
  std::vector<dem::BoundaryView> b{{"base", {-0.2, 0.6}, {0.0, 0.0}, false, false}};
  std::string err;
  { std::ofstream(d / "s.particles.dat") << "0 0 1 0\n"; } // an earlier version's disks table
  ASSERT_TRUE(compare::plot_particles(p, c, b, {"three disks", true, 4.0}, d / "s.png", &err))
      << err;
  EXPECT_FALSE(fs::exists(d / "s.particles.dat")); // not left beside this run's figure
  EXPECT_TRUE(is_png(d / "s.png"));
  EXPECT_FALSE(fs::exists(d / "s.svg")); // PNG only (plot.hpp); the script says how to get one
  EXPECT_TRUE(fs::exists(d / "s.gp"));
  EXPECT_TRUE(fs::exists(d / "s.chains.dat"));
  // the particles: one image (1,000 pixels along the longer side of their extent, 0.6 m × 0.2 m)
  // placed behind the plot, not a circle per disk
  EXPECT_TRUE(is_png(d / "s.particles.png"));
  EXPECT_EQ(png_pixels(d / "s.particles.png").size(), 4u * 1001u * 335u);
  {
    std::ifstream g(d / "s.gp");
    const std::string text((std::istreambuf_iterator<char>(g)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("set pixmap 1 's.particles.png' at first -0.1,0 size first"),
              std::string::npos)
        << text;
    EXPECT_EQ(text.find("with circles"), std::string::npos);
  }
  // Every particle gone from the model (a runout past the domain's end): the figure is drawn
  // without a particle layer (the extent of no disk once made a grid of 2³¹ pixels)
  dem::Particles gone = p;
  for (auto& f : gone.flags) f = dem::kFlagRemoved;
  ASSERT_TRUE(compare::plot_particles(gone, {}, b, {"no disks", true, 4.0}, d / "e.png", &err))
      << err;
  EXPECT_TRUE(is_png(d / "e.png"));
  EXPECT_FALSE(fs::exists(d / "e.particles.png"));
  // A velocity field draws arrows, not chains: it writes no chains file (7.6 MB at 10⁵ disks)
  ASSERT_TRUE(compare::plot_particles(p, c, b, {"three disks", true, 4.0, true}, d / "v.png", &err))
      << err;
  EXPECT_TRUE(is_png(d / "v.png"));
  EXPECT_TRUE(fs::exists(d / "v.velocity.dat"));
  EXPECT_FALSE(fs::exists(d / "v.chains.dat"));
  // its arrows: the mean velocity in each of 48 cells along the particles' longer side (0.6 m:
  // cells of 0.0125 m, one disk centre in each of three), centred on the cell's centre, the
  // longest (0.2 m/s) 0.9 cells long; a NaN line ends the file
  std::ifstream v(d / "v.velocity.dat");
  std::vector<std::array<double, 4>> arrows;
  std::string line;
  while (std::getline(v, line)) {
    std::istringstream ls(line);
    std::array<double, 4> a{};
    if (ls >> a[0] >> a[1] >> a[2] >> a[3] && std::isfinite(a[0])) arrows.push_back(a);
  }
  ASSERT_EQ(arrows.size(), 3u); // one arrow per disk here, where 10⁶ disks make ≤ 48 × 48
  const double cell = 0.6 / 48.0;
  for (std::size_t k = 0; k < 3; ++k) {
    const double vx = 0.1 * static_cast<double>(k);
    EXPECT_NEAR(arrows[k][2], 0.9 * cell * vx / 0.2, 1e-9) << k;
    EXPECT_NEAR(arrows[k][3], 0.0, 1e-12);
    const double cx = arrows[k][0] + 0.5 * arrows[k][2]; // the cell's centre
    EXPECT_NEAR(std::fmod(cx - (-0.1), cell), 0.5 * cell, 1e-9) << k;
  }
}

// A run's figures are queued and drawn a few scripts per gnuplot process: one result per figure
// in order, the failing one named by its own script (its process's scripts are run again one by
// one), and no setting of one script reaching the next (a log-scale plot before a linear one
// draws the linear one byte for byte as alone).
TEST(Plot, QueuedFiguresDrawnTogetherWithErrorsNamed) {
  const auto d = tmpdir("plot_queue");
  auto spec = [](bool log_y, const std::string& extra) {
    compare::PlotSpec s;
    s.title = log_y ? "log" : "linear";
    s.xlabel = "x";
    s.ylabel = "y";
    compare::Series se;
    se.label = "y";
    for (int i = 1; i <= 20; ++i) {
      se.x.push_back(i);
      se.y.push_back(i * i);
    }
    se.extra = extra;
    s.series = {se};
    s.log_y = log_y;
    return s;
  };
  const auto alone = d / "alone.png";
  ASSERT_TRUE(compare::plot(spec(false, ""), alone));
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  for (const unsigned processes : {1u, 2u}) {
    SCOPED_TRACE(processes);
    compare::PlotQueue q;
    const std::vector<std::string> names{"a_log", "b_linear", "c_bad", "d_linear"};
    for (const auto& n : names) {
      fs::remove(d / (n + ".png"));
      ASSERT_TRUE(compare::plot(spec(n == "a_log", n == "c_bad" ? "no-such-option 3" : ""),
                                d / (n + ".png"), nullptr, &q));
    }
    EXPECT_FALSE(fs::exists(d / "a_log.png")); // queued, not drawn yet
    const auto err = compare::draw_queued(q, processes);
    ASSERT_EQ(err.size(), 4u);
    for (std::size_t k = 0; k < 4; ++k) {
      if (names[k] == "c_bad") {
        EXPECT_NE(err[k].find("c_bad.gp"), std::string::npos) << err[k];
        continue;
      }
      EXPECT_TRUE(err[k].empty()) << names[k] << ": " << err[k];
      EXPECT_TRUE(is_png(d / (names[k] + ".png"))) << names[k];
    }
    EXPECT_EQ(bytes(d / "b_linear.png"), bytes(alone)); // after the log-scale one
    EXPECT_EQ(bytes(d / "d_linear.png"), bytes(alone)); // after the failing one
  }
}

// Several gnuplot scripts at once (the run's snapshot series): one result per script in order,
// the failing script's console kept in <script>.log and named, the others' logs removed, and
// every good script's output written, whatever the number of processes at once.
TEST(Plot, ScriptsRunTogetherWithErrorsInOrder) {
  const auto d = tmpdir("gnuplot_jobs");
  std::vector<fs::path> scripts;
  for (int k = 0; k < 5; ++k) {
    const fs::path gp = d / fmt::format("s{}.gp", k);
    std::ofstream g(gp);
    if (k == 2)
      g << "this is not gnuplot\n";
    else
      g << "set terminal pngcairo size 200,150\nset output '"
        << (d / fmt::format("s{}.png", k)).string() << "'\nplot sin(x)\n";
    scripts.push_back(gp);
  }
  for (const unsigned parallel : {1u, 2u, 0u}) {
    SCOPED_TRACE(parallel);
    for (int k = 0; k < 5; ++k) fs::remove(d / fmt::format("s{}.png", k));
    const auto err = compare::detail::run_gnuplot_scripts(scripts, parallel);
    ASSERT_EQ(err.size(), 5u);
    for (int k = 0; k < 5; ++k) {
      const auto log = scripts[static_cast<std::size_t>(k)].string() + ".log";
      if (k == 2) {
        EXPECT_NE(err[2].find("gnuplot failed (exit"), std::string::npos) << err[2];
        EXPECT_NE(err[2].find(log), std::string::npos) << err[2];
        EXPECT_TRUE(fs::exists(log));
      } else {
        EXPECT_TRUE(err[static_cast<std::size_t>(k)].empty()) << err[static_cast<std::size_t>(k)];
        EXPECT_TRUE(is_png(d / fmt::format("s{}.png", k))) << k;
        EXPECT_FALSE(fs::exists(log)) << log;
      }
    }
  }
}

// A job's scripts named relative to the working directory (a run with a relative --out), the first
// of them changing gnuplot's directory as every figure script does: the whole job succeeds in its
// one process. (With the names passed as given, gnuplot looked for the second script in the
// first's folder and failed the job, and draw_queued drew every figure again one by one.)
TEST(Plot, RelativeScriptNamesSurviveTheScriptsCd) {
  const auto d = tmpdir("gnuplot_relative");
  fs::create_directories(d / "elsewhere");
  const fs::path here = fs::current_path();
  fs::current_path(d);
  std::vector<fs::path> job;
  for (int k = 0; k < 3; ++k) {
    const fs::path gp = fs::path("figs") / ("r" + std::to_string(k) + ".gp");
    fs::create_directories(gp.parent_path());
    std::ofstream g(gp);
    g << "cd '" << (d / "elsewhere").string() << "'\nset terminal pngcairo size 120,90\n"
      << "set output 'r" << k << ".png'\nplot x\n";
    job.push_back(gp);
  }
  const auto err = compare::detail::run_gnuplot_jobs({job}, 1);
  fs::current_path(here);
  ASSERT_EQ(err.size(), 1u);
  EXPECT_TRUE(err[0].empty()) << err[0];
  for (int k = 0; k < 3; ++k)
    EXPECT_TRUE(is_png(d / "elsewhere" / ("r" + std::to_string(k) + ".png"))) << k;
}

// A group of queued figures that fails in one process although each script draws alone (here the
// first script's `cd` hides the second's data file, named relative to where gnuplot started) is
// drawn one script per process, every figure made, and a warning says so: the grouping itself is
// broken, and every figure costs twice.
TEST(Plot, AGroupThatFailsOnlyTogetherIsReported) {
  const auto d = tmpdir("plot_group_warn");
  fs::create_directories(d / "elsewhere");
  std::ofstream(d / "data.dat") << "1 1\n2 4\n";
  const fs::path here = fs::current_path();
  fs::current_path(d);
  compare::PlotQueue q;
  const std::vector<std::string> body{"cd '" + (d / "elsewhere").string() + "'\nplot x\n",
                                      "plot 'data.dat' with lines\n"};
  for (std::size_t k = 0; k < body.size(); ++k) {
    const fs::path gp = d / ("g" + std::to_string(k) + ".gp");
    const fs::path png = d / ("g" + std::to_string(k) + ".png");
    std::ofstream(gp) << "set terminal pngcairo size 120,90\nset output '" << png.string() << "'\n"
                      << body[k];
    q.scripts.push_back(gp);
    q.pngs.push_back(png);
  }
  std::ostringstream log;
  const auto previous = spdlog::default_logger();
  spdlog::set_default_logger(std::make_shared<spdlog::logger>(
      "plot-test", std::make_shared<spdlog::sinks::ostream_sink_st>(log)));
  const auto err = compare::draw_queued(q, 1); // one process: both scripts in one group
  spdlog::set_default_logger(previous);
  fs::current_path(here);
  ASSERT_EQ(err.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_TRUE(err[k].empty()) << err[k];
    EXPECT_TRUE(is_png(q.pngs[k])) << k;
  }
  EXPECT_NE(log.str().find("failed when run in one process but each drew alone"), std::string::npos)
      << log.str();
}

namespace {
// FLEVEL of a PNG's zlib stream (the second byte of its first IDAT's data, bits 6–7): 0 for zlib
// levels 0–1, 1 for 2–5, 2 for 6 (libpng's default), 3 for 7–9; −1 when there is no IDAT.
int png_zlib_flevel(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  const std::string d((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto at = d.find("IDAT");
  if (at == std::string::npos || at + 6 > d.size()) return -1;
  return static_cast<unsigned char>(d[at + 5]) >> 6;
}
std::vector<unsigned char> png_pixels(const fs::path& p) {
  vtkNew<vtkPNGReader> r;
  r->SetFileName(p.string().c_str());
  r->Update();
  auto* s = r->GetOutput()->GetPointData()->GetScalars();
  std::vector<unsigned char> v;
  for (vtkIdType i = 0; i < s->GetNumberOfValues(); ++i)
    v.push_back(static_cast<unsigned char>(s->GetVariantValue(i).ToInt()));
  return v;
}
} // namespace

// The gnuplot processes demfem starts encode their PNGs with zlib level 3 (png_preload.cpp), not
// libpng's default level 6, and draw the same pixels; DEMFEM_PNG_PRELOAD=0 turns the module off.
TEST(Plot, PngsEncodedFastWithTheSamePixels) {
  const auto d = tmpdir("gnuplot_png_level");
  const fs::path gp = d / "f.gp", png = d / "f.png";
  {
    std::ofstream g(gp);
    g << "set terminal pngcairo size 400,300\nset output '" << png.string()
      << "'\nplot sin(x) with lines lw 3, cos(x) with points pt 7 lc rgb 'red'\n";
  }
  const auto draw = [&] {
    fs::remove(png);
    const auto err = compare::detail::run_gnuplot_scripts({gp}, 1);
    EXPECT_TRUE(err.at(0).empty()) << err.at(0);
    return is_png(png);
  };
  ASSERT_TRUE(draw());
  EXPECT_EQ(png_zlib_flevel(png), 1);
  const auto fast = png_pixels(png);
  ::setenv("DEMFEM_PNG_PRELOAD", "0", 1);
  const bool drawn = draw();
  ::unsetenv("DEMFEM_PNG_PRELOAD");
  ASSERT_TRUE(drawn);
  EXPECT_EQ(png_zlib_flevel(png), 2); // libpng's default
  const auto plain = png_pixels(png);
  ASSERT_FALSE(fast.empty());
  EXPECT_TRUE(fast == plain) << "the module changed the pixels";
}

// The peak speeds of summary.json come from every particles_*.vtp of the run: of all particles,
// and of those at or above the lowest ground point; a removed particle is in no snapshot.
TEST(Figures, PeakSnapshotSpeedsOfAllAndAboveAHeight) {
  const auto d = tmpdir("peak_speeds");
  const auto snapshot = [&](int k, std::vector<std::array<double, 3>> zvv) { // z, vx, vz
    dem::Particles p;
    for (std::size_t q = 0; q < zvv.size(); ++q) {
      p.x.push_back(static_cast<double>(q));
      p.z.push_back(zvv[q][0]);
      p.vx.push_back(zvv[q][1]);
      p.vz.push_back(zvv[q][2]);
      for (auto* v : {&p.phi, &p.omega, &p.fx, &p.fz, &p.torque}) v->push_back(0.0);
      p.radius.push_back(0.1);
      p.mass.push_back(1.0);
      p.inv_mass.push_back(1.0);
      p.inv_inertia.push_back(1.0);
      p.id.push_back(static_cast<std::uint32_t>(q));
      p.material.push_back(0);
      p.flags.push_back(q == 2 ? dem::kFlagRemoved : dem::kFlagNone);
    }
    dem::io::write_particles_vtp(d / dem::io::numbered_file_name("particles", k, "vtp"), p);
  };
  snapshot(0, {{2.0, 3.0, 4.0}, {-1.0, 0.0, 7.0}, {5.0, 100.0, 0.0}});  // 5 above, 7 below
  snapshot(1, {{1.0, 6.0, 0.0}, {-2.0, 0.0, -9.0}, {5.0, 100.0, 0.0}}); // 6 above, 9 below
  const auto pk = compare::peak_snapshot_speeds(d, 0.0);
  EXPECT_DOUBLE_EQ(pk.all, 9.0);
  EXPECT_DOUBLE_EQ(pk.above, 6.0);
  EXPECT_DOUBLE_EQ(compare::peak_snapshot_speeds(d).above, 9.0); // no height: every particle
  EXPECT_EQ(compare::peak_snapshot_speeds(d / "none").all, 0.0);
}

// The particle layer's encoder: a grid of a few pixels round-trips through VTK's reader, with
// transparency between the disks; an empty grid is an error, not a crash.
TEST(Raster, LayerReadsBackAndAnEmptyGridIsAnError) {
  const auto d = tmpdir("raster_layer");
  const compare::detail::Raster g = compare::detail::raster_grid(0.0, 4.0, 0.0, 2.0, 4.0);
  ASSERT_EQ(g.w, 5);
  ASSERT_EQ(g.h, 3);
  {
    std::ofstream f(d / "l.png", std::ios::binary);
    f << compare::detail::raster_png(g, {{0.5, 0.5, 0.4, 0.0, 0.0, 0.0}}, 1.0, nullptr);
  }
  const auto px = png_pixels(d / "l.png"); // RGBA, row 0 at the bottom
  ASSERT_EQ(px.size(), 4u * 5u * 3u);
  EXPECT_EQ(px[0], 0x2c); // pixel (0, 0): the disk, the palette's first colour, opaque
  EXPECT_EQ(px[3], 255);
  EXPECT_EQ(px[4 * (2 * 5 + 4) + 3], 0); // pixel (4, 2): transparent
  compare::detail::Raster empty = g;
  empty.w = empty.h = 0;
  EXPECT_THROW((void)compare::detail::raster_png(empty, {}, 1.0, nullptr), std::runtime_error);
  EXPECT_EQ(compare::detail::raster_grid(1e300, -1e300, 0.0, 1.0, 100.0).w, 0);
}

// The chains a figure draws: the `cap` largest |f_n| (ties: the lower index; NaN the smallest),
// in the contacts' order; every contact when there are at most `cap`.
TEST(Raster, StrongestChainsInTheirOrder) {
  using compare::detail::strongest;
  const double nan = std::nan("");
  const std::vector<double> m{3.0, 9.0, nan, 1.0, 9.0, 7.0, 3.0};
  EXPECT_EQ(strongest(m, 3), (std::vector<std::size_t>{1, 4, 5}));
  EXPECT_EQ(strongest(m, 4), (std::vector<std::size_t>{0, 1, 4, 5})); // 0 before 6 (equal)
  EXPECT_EQ(strongest(m, 6), (std::vector<std::size_t>{0, 1, 3, 4, 5, 6}));
  EXPECT_EQ(strongest(m, 7).size(), 7u);
  EXPECT_EQ(strongest(m, 100).size(), 7u);
  EXPECT_TRUE(strongest(m, 0).empty());
  EXPECT_TRUE(strongest({}, 5).empty());
}

// A snapshot with more contacts than max_chain_lines draws the strongest of them and says so in
// its title (10⁶ disks: 1.7 million sub-pixel lines, a 77 MB table and 3 s of gnuplot before).
TEST(Plot, SnapshotDrawsTheStrongestChainsWhenThereAreMany) {
  const auto d = tmpdir("snap_cap");
  const dem::Particles p = disk_row(40, 0.0);
  std::vector<dem::ContactView> c;
  for (std::uint32_t i = 0; i + 1 < 40; ++i) // |f_n| = i + 1; every third pair in tension
    c.push_back(
        {i, i + 1, 0.2 * i + 0.1, 0.1, (i % 3 == 2 ? -1.0 : 1.0) * (i + 1), 0.0, i % 3 == 2});
  c.push_back({5, -1, 1.0, 0.0, 1000.0, 0.0, false}); // a wall contact: never a chain
  compare::SnapshotSpec spec{"forty disks", true, 4.0};
  spec.max_chain_lines = 10;
  std::string err;
  ASSERT_TRUE(compare::plot_particles(p, c, {}, spec, d / "s.png", &err)) << err;
  EXPECT_TRUE(is_png(d / "s.png"));
  std::ifstream f(d / "s.chains.dat");
  std::vector<double> x0;
  std::string line;
  while (std::getline(f, line)) {
    std::istringstream ls(line);
    double a = 0.0;
    if (line.empty() || line[0] == '#' || !(ls >> a) || !std::isfinite(a)) continue;
    x0.push_back(a);
  }
  std::sort(x0.begin(), x0.end());
  ASSERT_EQ(x0.size(), 10u); // the pairs 29 … 38 (|f_n| 30 … 39)
  for (std::size_t k = 0; k < 10; ++k) EXPECT_NEAR(x0[k], 0.2 * (29 + k), 1e-9) << k;
  std::ifstream g(d / "s.gp");
  const std::string text((std::istreambuf_iterator<char>(g)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("forty disks (chains: the strongest 10 of 39 contacts)"), std::string::npos)
      << text;
  // at most max_chain_lines: all drawn, the title as given
  spec.max_chain_lines = 39;
  ASSERT_TRUE(compare::plot_particles(p, c, {}, spec, d / "a.png", &err)) << err;
  std::ifstream ga(d / "a.gp");
  const std::string ta((std::istreambuf_iterator<char>(ga)), std::istreambuf_iterator<char>());
  EXPECT_NE(ta.find("set title 'forty disks' noenhanced"), std::string::npos) << ta;
}
