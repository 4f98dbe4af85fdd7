// Snapshot series (compare/series.hpp): the particle layer drawn as images, the velocity arrows as
// cell means. A 40-disk box run for 0.2 s gives three snapshots.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <vtkImageData.h>
#include <vtkPNGReader.h>
#include <vtkSmartPointer.h>

#include "../scratch.hpp"

#include "demfem/app/vocabulary.hpp"
#include "demfem/compare/series.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/scene/load.hpp"

namespace fs = std::filesystem;
using namespace demfem;

namespace {

struct Disk {
  double x, z, r, vx, vz;
};

// Four rows of ten disks r = 0.04 m in a 1 m × 1 m box, at rest except the first, which moves.
std::vector<Disk> box_disks() {
  std::vector<Disk> d;
  for (int k = 0; k < 40; ++k)
    d.push_back({0.06 + 0.098 * (k % 10), 0.05 + 0.085 * (k / 10), 0.04, k == 0 ? 1.5 : 0.0, 0.0});
  return d;
}

std::string box_scene(const std::vector<Disk>& disks) {
  std::string ps;
  for (const auto& p : disks)
    ps += fmt::format("{}[{}, {}, {}, {}, {}, 0.0]", ps.empty() ? "" : ", ", p.x, p.z, p.r, p.vx,
                      p.vz);
  return fmt::format(R"([scene]
name = "series-box"
duration = 0.2
[domain]
polygon = [[0, 0], [1, 0], [1, 1], [0, 1]]
[soil.dem]
count = {}
radius = {{ equal = 0.04 }}
kn = 1e6
ks = 3e5
particles = [{}]
[[wall]]
name = "box"
points = [[0, 1], [0, 0], [1, 0], [1, 1]]
[load]
gravity = 9.81
[[probe]]
kind = "loci"
points = [[0.5, 0.2], [0.3, 0.1]]
[output]
interval = 0.1
probe_interval = 0.01
figures = false
series = [0, 0.1, 0.2]
)",
                     disks.size(), ps);
}

// RGBA of pixel (i, j) (row 0 at the bottom) of a PNG read back through VTK.
struct Png {
  vtkSmartPointer<vtkImageData> img;
  int w = 0, h = 0;
  const unsigned char* at(int i, int j) const {
    return static_cast<const unsigned char*>(img->GetScalarPointer(i, j, 0));
  }
};
Png read_png(const fs::path& f) {
  auto r = vtkSmartPointer<vtkPNGReader>::New();
  r->SetFileName(f.string().c_str());
  r->Update();
  Png p;
  p.img = r->GetOutput();
  int dims[3];
  p.img->GetDimensions(dims);
  p.w = dims[0];
  p.h = dims[1];
  return p;
}

} // namespace

// The particles are images of 640 pixels along the longer side, opaque inside every disk (the
// grey layer: #d8d8d8; the coloured one: the palette's colour of the disk's speed, #2c7bb6 for
// a disk at rest) and transparent outside; the velocity arrows are one per occupied cell, no
// longer than 0.9 cells.
TEST(SnapshotSeries, ParticlesAsImagesAndVelocityAsCellMeans) {
  const auto disks = box_disks();
  const auto file =
      scene::parse_scene(box_scene(disks), "series_box.toml", demfem::app::vocabulary());
  dem::RunOptions o;
  o.out_dir = test::scratch("series_box");
  const auto s = dem::run(file.base, o);
  ASSERT_TRUE(s.ok) << s.message;
  const auto res = compare::write_snapshot_series(file.base, o.out_dir);
  for (const auto& p : res.problems) ADD_FAILURE() << p;
  ASSERT_EQ(res.figures.size(), 3u);
  for (const auto& f : res.figures) EXPECT_TRUE(fs::file_size(f) > 0) << f;
  ASSERT_EQ(res.times.size(), 3u);
  EXPECT_EQ(res.times[0], 0.0);

  const fs::path dat = o.out_dir / "figures" / "series";
  // the strip's extent (the box's walls and every disk of the three frames), from its script,
  // and where it puts each panel's particle image (a pixmap behind the panel's plot)
  double x0 = NAN, x1 = NAN, z0 = NAN, z1 = NAN;
  struct Pixmap {
    int index = 0;
    char file[32] = {};
    double x = NAN, z = NAN, w = NAN, h = NAN;
  };
  std::vector<Pixmap> pixmaps;
  int unset = 0, boxes = 0;
  double box_x = NAN;
  {
    std::ifstream gp(o.out_dir / "figures" / "series_velocity.gp");
    std::string l;
    while (std::getline(gp, l)) {
      if (l.rfind("set xrange [", 0) == 0) std::sscanf(l.c_str(), "set xrange [%lf:%lf]", &x0, &x1);
      if (l.rfind("set yrange [", 0) == 0) std::sscanf(l.c_str(), "set yrange [%lf:%lf]", &z0, &z1);
      Pixmap m;
      if (std::sscanf(l.c_str(), "set pixmap %d '%31[^']' at first %lf,%lf size first %lf,%lf",
                      &m.index, m.file, &m.x, &m.z, &m.w, &m.h) == 6)
        pixmaps.push_back(m);
      if (l.rfind("unset pixmap ", 0) == 0) ++unset;
      if (l.rfind("set colorbox", 0) == 0) ++boxes;
      if (l.rfind("set colorbox user origin screen ", 0) == 0)
        std::sscanf(l.c_str(), "set colorbox user origin screen %lf", &box_x);
    }
  }
  ASSERT_EQ(pixmaps.size(), 3u); // one per panel, each removed before the next panel
  EXPECT_EQ(unset, 3);
  // 3 panels in 1 × 3 fill the layout: the one colour box (each costs ≈ 50 ms of pngcairo) in a
  // column of its own at the right of the panels
  EXPECT_EQ(boxes, 1);
  EXPECT_GT(box_x, 0.9);
  ASSERT_TRUE(std::isfinite(x0) && std::isfinite(z0)) << "no ranges in series_velocity.gp";
  EXPECT_NEAR(x0, 0.0, 0.01);
  EXPECT_NEAR(x1 - x0, 1.0, 0.01);
  const double ext = std::max(x1 - x0, z1 - z0), px = ext / 640.0;
  const Png grey = read_png(dat / "g0.png"), col = read_png(dat / "p0.png");
  EXPECT_EQ(grey.w, static_cast<int>(std::ceil((x1 - x0) / px)) + 1);
  EXPECT_EQ(grey.h, static_cast<int>(std::ceil((z1 - z0) / px)) + 1);
  EXPECT_EQ(std::max(grey.w, grey.h), 641);
  ASSERT_EQ(col.w, grey.w);
  for (std::size_t k = 0; k < pixmaps.size(); ++k) { // the image covers its pixels' rectangle
    EXPECT_EQ(pixmaps[k].index, static_cast<int>(k) + 1);
    char want[32];
    std::snprintf(want, sizeof want, "p%zu.png", k);
    EXPECT_STREQ(pixmaps[k].file, want);
    EXPECT_NEAR(pixmaps[k].x, x0, 1e-6);
    EXPECT_NEAR(pixmaps[k].z, z0, 1e-6);
    EXPECT_NEAR(pixmaps[k].w, col.w * px, 1e-6);
    EXPECT_NEAR(pixmaps[k].h, col.h * px, 1e-6);
  }
  auto pixel = [&](double x, double z) {
    return std::pair<int, int>{static_cast<int>(std::floor((x - x0) / px)),
                               static_cast<int>(std::floor((z - z0) / px))};
  };
  int inside = 0;
  for (std::size_t k = 0; k < disks.size(); ++k) {
    const auto [i, j] = pixel(disks[k].x, disks[k].z); // t = 0: the listed positions
    const unsigned char* g = grey.at(i, j);
    EXPECT_EQ(g[3], 255) << "disk " << k;
    EXPECT_EQ(g[0], 0xd8);
    if (k == 0) continue;
    const unsigned char* c = col.at(i, j); // at rest: the palette's first colour
    EXPECT_EQ(c[0], 0x2c) << "disk " << k;
    EXPECT_EQ(c[1], 0x7b);
    EXPECT_EQ(c[2], 0xb6);
    EXPECT_EQ(c[3], 255);
    ++inside;
  }
  EXPECT_EQ(inside, 39);
  const unsigned char* moving =
      col.at(pixel(disks[0].x, disks[0].z).first, pixel(disks[0].x, disks[0].z).second);
  EXPECT_NE(moving[2], 0xb6) << "the moving disk is not drawn in the colour of rest";
  // above the bed (z > 0.4 m) and between two disks of a row: transparent
  for (const auto& [x, z] : {std::pair{0.5, 0.8}, std::pair{0.1, 0.95}, std::pair{0.109, 0.05}})
    EXPECT_EQ(grey.at(pixel(x, z).first, pixel(x, z).second)[3], 0) << x << ", " << z;

  // velocity arrows at t = 0.1 s: x, z, dx, dz, centred on their cell's centre; cells of 1/36
  // of the longer side
  std::ifstream v(dat / "v1.dat");
  std::string line;
  int arrows = 0;
  const double cell = ext / 36.0;
  while (std::getline(v, line)) {
    std::istringstream ls(line);
    double x, z, dx, dz;
    if (!(ls >> x >> z >> dx >> dz) || !std::isfinite(x)) continue;
    ++arrows;
    EXPECT_LE(std::hypot(dx, dz), 0.9 * cell * (1 + 1e-9));
    // the arrow is centred on its cell's centre
    const double cx = (x + 0.5 * dx - x0) / cell, cz = (z + 0.5 * dz - z0) / cell;
    EXPECT_NEAR(cx - std::floor(cx), 0.5, 1e-5); // the file's 7 digits
    EXPECT_NEAR(cz - std::floor(cz), 0.5, 1e-5);
  }
  EXPECT_GE(arrows, 10);
  EXPECT_LE(arrows, 40); // one per occupied cell, at most one cell per disk here
  fs::remove_all(o.out_dir);
}

// A panel with more chains than max_chain_lines draws the strongest of them, and the strip's title
// says so (10⁶ disks: 1.7 million sub-pixel lines per panel before); with the default every chain
// of this small box is drawn and the title is as before.
TEST(SnapshotSeries, PanelsDrawTheStrongestChainsWhenThereAreMany) {
  const auto file =
      scene::parse_scene(box_scene(box_disks()), "series_box_cap.toml", demfem::app::vocabulary());
  dem::RunOptions o;
  o.out_dir = test::scratch("series_box_cap");
  ASSERT_TRUE(dem::run(file.base, o).ok);
  const fs::path dat = o.out_dir / "figures" / "series";
  auto lines = [&](std::size_t k) { // chains in panel k's table
    std::ifstream f(dat / fmt::format("c{}.dat", k));
    std::size_t n = 0;
    std::string l;
    while (std::getline(f, l)) {
      std::istringstream ls(l);
      double x = NAN;
      if (!l.empty() && l[0] != '#' && (ls >> x) && std::isfinite(x)) ++n;
    }
    return n;
  };
  auto title = [&] {
    std::ifstream g(o.out_dir / "figures" / "series_force_chains.gp");
    return std::string((std::istreambuf_iterator<char>(g)), std::istreambuf_iterator<char>());
  };
  auto all = compare::write_snapshot_series(file.base, o.out_dir);
  for (const auto& p : all.problems) ADD_FAILURE() << p;
  std::vector<std::size_t> n;
  for (std::size_t k = 0; k < 3; ++k) n.push_back(lines(k));
  const std::size_t most = *std::max_element(n.begin(), n.end());
  ASSERT_GT(most, 4u) << "the settled box has chains";
  EXPECT_EQ(title().find("the strongest"), std::string::npos);
  const auto capped = compare::write_snapshot_series(file.base, o.out_dir, 4);
  for (const auto& p : capped.problems) ADD_FAILURE() << p;
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(lines(k), std::min<std::size_t>(n[k], 4)) << k;
  EXPECT_NE(title().find(fmt::format("the strongest 4 of up to {} per panel", most)),
            std::string::npos)
      << title();
  fs::remove_all(o.out_dir);
}
