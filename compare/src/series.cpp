#include "demfem/compare/series.hpp"
#include "demfem/compare/gnuplot_run.hpp"
#include "demfem/compare/out_file.hpp"
#include "demfem/compare/raster.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkIdList.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>

#include "demfem/compare/plot.hpp"
#include "demfem/output/contract.hpp"

namespace demfem::compare {

namespace fs = std::filesystem;

std::vector<double> series_times(const scene::Scene& scene) {
  std::vector<double> t;
  const double end = scene.info.duration;
  for (double v : scene.output.series)
    if (v <= end + 1e-9) t.push_back(v);
  if (scene.output.series.empty())
    for (int k = 0; k < 6; ++k) t.push_back(end * k / 5.0);
  return t;
}

std::vector<std::pair<double, fs::path>> read_pvd(const fs::path& pvd) {
  std::vector<std::pair<double, fs::path>> out;
  std::ifstream in(pvd);
  if (!in) return out;
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  auto attr = [](const std::string& el, const std::string& name) -> std::string {
    const auto k = el.find(name + "=\"");
    if (k == std::string::npos) return {};
    const auto b = k + name.size() + 2;
    const auto e = el.find('"', b);
    return e == std::string::npos ? std::string() : el.substr(b, e - b);
  };
  std::size_t pos = 0;
  while ((pos = text.find("<DataSet", pos)) != std::string::npos) {
    const auto end = text.find("/>", pos);
    if (end == std::string::npos) break;
    const std::string el = text.substr(pos, end - pos);
    pos = end;
    const std::string ts = attr(el, "timestep"), file = attr(el, "file");
    if (ts.empty() || file.empty()) continue;
    fs::path f(file);
    if (f.is_relative()) f = pvd.parent_path() / f;
    out.emplace_back(std::strtod(ts.c_str(), nullptr), f);
  }
  return out;
}

namespace {

using Disk = detail::RasterDisk; // x, z, r, vx, vz, speed
struct Chain {
  double x0, z0, x1, z1, fn;
  bool tensile;
};
struct Frame {
  double time = 0.0;
  std::vector<Disk> disks;
  std::vector<Chain> chains;
  std::vector<std::vector<std::pair<double, double>>> lines; // boundaries (open walls left out)
};

vtkSmartPointer<vtkPolyData> read_vtp(const fs::path& f) {
  std::error_code ec;
  if (!fs::exists(f, ec)) return nullptr;
  auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
  reader->SetFileName(f.string().c_str());
  reader->Update();
  auto pd = vtkSmartPointer<vtkPolyData>::New();
  pd->DeepCopy(reader->GetOutput());
  return pd;
}

// The .vtp files of the snapshot nearest to `t` in each collection (same index: the run writes
// particles, boundaries and chains together).
bool load_frame(const std::vector<std::pair<double, fs::path>>& particles,
                const std::vector<std::pair<double, fs::path>>& chains,
                const std::vector<std::pair<double, fs::path>>& bounds, std::size_t k, Frame& out) {
  out.time = particles[k].first;
  const auto pd = read_vtp(particles[k].second);
  if (!pd || !pd->GetPointData()) return false;
  vtkDataArray* rad = pd->GetPointData()->GetArray("radius");
  vtkDataArray* vel = pd->GetPointData()->GetArray("velocity");
  if (!rad) return false;
  for (vtkIdType i = 0; i < pd->GetNumberOfPoints(); ++i) {
    const double* x = pd->GetPoint(i);
    Disk d{x[0], x[1], rad->GetTuple1(i), 0.0, 0.0, 0.0};
    if (vel) {
      const double* v = vel->GetTuple3(i);
      d.vx = v[0];
      d.vz = v[1];
      d.speed = std::hypot(v[0], v[1]);
    }
    out.disks.push_back(d);
  }
  if (k < chains.size()) {
    if (const auto cd = read_vtp(chains[k].second); cd && cd->GetCellData()) {
      vtkDataArray* fn = cd->GetCellData()->GetArray("normal_force");
      vtkDataArray* te = cd->GetCellData()->GetArray("tensile");
      auto ids = vtkSmartPointer<vtkIdList>::New();
      for (vtkIdType c = 0; fn && c < cd->GetNumberOfCells(); ++c) {
        cd->GetCellPoints(c, ids);
        if (ids->GetNumberOfIds() != 2) continue;
        const double* a = cd->GetPoint(ids->GetId(0));
        const double a0 = a[0], a1 = a[1];
        const double* b = cd->GetPoint(ids->GetId(1));
        out.chains.push_back(
            {a0, a1, b[0], b[1], fn->GetTuple1(c), te ? te->GetTuple1(c) != 0.0 : false});
      }
    }
  }
  if (k < bounds.size()) {
    if (const auto bd = read_vtp(bounds[k].second); bd && bd->GetCellData()) {
      vtkDataArray* open = bd->GetCellData()->GetArray("open");
      auto ids = vtkSmartPointer<vtkIdList>::New();
      for (vtkIdType c = 0; c < bd->GetNumberOfCells(); ++c) {
        if (open && open->GetTuple1(c) != 0.0) continue;
        bd->GetCellPoints(c, ids);
        std::vector<std::pair<double, double>> line;
        for (vtkIdType q = 0; q < ids->GetNumberOfIds(); ++q) {
          const double* x = bd->GetPoint(ids->GetId(q));
          line.emplace_back(x[0], x[1]);
        }
        out.lines.push_back(std::move(line));
      }
    }
  }
  return true;
}

std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

} // namespace

SnapshotSeries write_snapshot_series(const scene::Scene& scene, const fs::path& run_dir,
                                     std::size_t max_chains) {
  SnapshotSeries res;
  res.requested = series_times(scene);
  const fs::path dem = run_dir / output::dir::dem;
  const auto parts = read_pvd(dem / output::file::particles_pvd);
  if (parts.empty()) {
    res.problems.push_back("snapshot series: no dem/particles.pvd (output.vtk off?)");
    return res;
  }
  const auto chains = read_pvd(dem / output::file::force_chains_pvd);
  const auto bounds = read_pvd(dem / output::file::boundaries_pvd);
  // Nearest snapshot to each requested time (a snapshot is drawn once).
  std::vector<std::size_t> picks;
  for (double t : res.requested) {
    std::size_t best = 0;
    for (std::size_t k = 1; k < parts.size(); ++k)
      if (std::abs(parts[k].first - t) < std::abs(parts[best].first - t)) best = k;
    if (picks.empty() || picks.back() != best) picks.push_back(best);
  }
  std::vector<Frame> frames;
  for (auto k : picks) {
    Frame f;
    if (load_frame(parts, chains, bounds, k, f))
      frames.push_back(std::move(f));
    else
      res.problems.push_back(
          fmt::format("snapshot series: cannot read {}", parts[k].second.string()));
  }
  if (frames.empty()) return res;
  for (const auto& f : frames) res.times.push_back(f.time);

  // One extent, speed scale and force scale for the whole strip.
  double xmin = 1e300, xmax = -1e300, zmin = 1e300, zmax = -1e300, vmax = 0.0, fmax = 0.0;
  for (const auto& f : frames) {
    for (const auto& d : f.disks) {
      xmin = std::min(xmin, d.x - d.r);
      xmax = std::max(xmax, d.x + d.r);
      zmin = std::min(zmin, d.z - d.r);
      zmax = std::max(zmax, d.z + d.r);
      vmax = std::max(vmax, d.speed);
    }
    for (const auto& l : f.lines)
      for (const auto& [x, z] : l) {
        xmin = std::min(xmin, x);
        xmax = std::max(xmax, x);
        zmin = std::min(zmin, z);
        zmax = std::max(zmax, z);
      }
    for (const auto& c : f.chains) fmax = std::max(fmax, std::abs(c.fn));
  }
  if (!(xmax > xmin)) xmin = 0, xmax = 1;
  if (!(zmax > zmin)) zmin = 0, zmax = 1;
  const double aspect = (zmax - zmin) / (xmax - xmin);
  const std::size_t n = frames.size();
  // Columns: 2 for a long, low domain; else 3, or 4 where that leaves fewer empty panels (the
  // wall's 7 frames: 4 + 3 in 2,800 × 1,200 pixels instead of 3 + 3 + 1 in 2,700 × 2,200, which
  // was 45 % white and cost twice the drawing and PNG encoding).
  std::size_t cols = 2;
  if (aspect >= 0.5) {
    const std::size_t empty3 = (3 - n % 3) % 3, empty4 = (4 - n % 4) % 4;
    cols = n <= 3 ? n : (n == 4 ? 2 : (empty4 <= empty3 && n > 6 ? 4 : 3));
  }
  cols = std::max<std::size_t>(1, std::min(cols, n));
  const std::size_t rows = (n + cols - 1) / cols;
  const int pw = cols >= 4 ? 700 : 900;
  const int ph = std::clamp(static_cast<int>(pw * aspect) + 90, 260, 1000);

  const fs::path fig = run_dir / "figures";
  const fs::path dat = fig / "series";
  fs::create_directories(dat);
  // Loci (traced particles) from loci.csv, if the scene has them.
  CsvTable loci;
  try {
    std::error_code ec;
    if (fs::exists(dem / output::file::loci, ec)) loci = read_csv(dem / output::file::loci);
  } catch (const std::exception& e) {
    res.problems.push_back(std::string("snapshot series: loci.csv: ") + e.what());
  }
  const auto lt = loci.column(output::col::time.name);

  constexpr int kClasses = 4;   // chain widths by |f_n| / max over the strip
  std::size_t chains_total = 0; // the most in a panel
  // Velocity arrows: cell means (raster.hpp), about 36 cells along the longer side, one scale for
  // the strip: the longest arrow is 0.9 cells.
  const double vcell = std::max(xmax - xmin, zmax - zmin) / 36.0;
  std::vector<detail::CellVelocity> cell_means;
  double vcell_max = 0.0;
  for (const auto& f : frames) {
    cell_means.push_back(detail::cell_mean_velocity(f.disks, xmin, xmax, zmin, zmax, vcell));
    vcell_max = std::max(vcell_max, cell_means.back().vmax);
  }
  const double vscale = vcell_max > 0.0 ? 0.9 * vcell / vcell_max : 0.0; // m per (m/s)
  // 640 pixels along the longer side: about a panel's plot area
  const detail::Raster grid = detail::raster_grid(xmin, xmax, zmin, zmax, 640.0);
  static constexpr unsigned char kGrey[3] = {0xd8, 0xd8, 0xd8}; // the particles behind the loci
  for (std::size_t k = 0; k < n; ++k) {
    const auto& f = frames[k];
    for (const bool grey : {false, true}) {
      OutFile d(dat / fmt::format("{}{}.png", grey ? "g" : "p", k));
      d << detail::raster_png(grid, f.disks, vmax, grey ? kGrey : nullptr);
      d.close();
    }
    {
      std::vector<double> magnitude;
      magnitude.reserve(f.chains.size());
      for (const auto& c : f.chains) magnitude.push_back(std::abs(c.fn));
      const auto drawn = detail::strongest(magnitude, max_chains);
      chains_total = std::max(chains_total, f.chains.size());
      OutFile d(dat / fmt::format("c{}.dat", k));
      d.precision(7);
      for (int block = 0; block < 2 * kClasses; ++block) {
        const bool tension = block >= kClasses;
        d << "# " << (tension ? "tension" : "compression") << " class " << block % kClasses << "\n";
        bool any = false;
        for (const std::size_t q : drawn) {
          const auto& c = f.chains[q];
          if (c.tensile != tension || fmax <= 0.0) continue;
          const int cls =
              std::min(kClasses - 1, static_cast<int>(kClasses * std::abs(c.fn) / fmax));
          if (cls != block % kClasses) continue;
          d << c.x0 << " " << c.z0 << " " << c.x1 - c.x0 << " " << c.z1 - c.z0 << "\n";
          any = true;
        }
        if (!any) d << "NaN NaN NaN NaN\n";
        d << "\n\n";
      }
      d.close();
    }
    {
      OutFile d(dat / fmt::format("v{}.dat", k));
      d << detail::cell_arrows(cell_means[k], xmin, zmin, vscale);
      d.close();
    }
    {
      OutFile d(dat / fmt::format("b{}.dat", k));
      d.precision(7);
      for (const auto& l : f.lines) {
        for (const auto& [x, z] : l) d << x << " " << z << "\n";
        d << "\n";
      }
      d << "NaN NaN\n";
      d.close();
    }
    {
      OutFile d(dat / fmt::format("l{}.dat", k));
      d.precision(7);
      for (std::size_t c = 1; c + 1 < loci.columns.size(); c += 2) {
        const auto x = loci.column(loci.columns[c].substr(0, loci.columns[c].find(" [")));
        const auto z = loci.column(loci.columns[c + 1].substr(0, loci.columns[c + 1].find(" [")));
        for (std::size_t i = 0; i < std::min({x.size(), z.size(), lt.size()}); ++i)
          if (lt[i] <= f.time + 1e-9 && std::isfinite(x[i]) && std::isfinite(z[i]))
            d << x[i] << " " << z[i] << "\n";
        d << "\n";
      }
      d << "NaN NaN\n";
      d.close();
    }
  }

  // Every panel has the same colour range: one colour box, drawn with the last panel. pngcairo
  // draws a colour box as an image composited over the whole canvas, ≈ 50 ms each on these
  // canvases: 7 of them were 0.4 s of a 0.7 s strip (without its particles and vectors), the
  // footing's 6 were 0.32 s of its 0.9 s strip. It goes in the first empty slot of the layout when
  // there is one (the wall's 7 panels in 2 × 4), else in a column of its own at the right of the
  // canvas (the footing's 6 in 2 × 3: the panels are then placed one by one, as the layout would).
  const bool one_box = rows * cols > n;
  constexpr int kBarColumn = 150; // pixels: the colour box, its tick labels and its label
  enum class Kind { Chains, Velocity, Loci };
  std::vector<fs::path> scripts, pngs; // drawn together below, one gnuplot per core
  auto strip = [&](Kind kind, const std::string& name, const std::string& what) {
    if (kind == Kind::Loci && loci.columns.size() < 3) return;
    const fs::path png = fig / (name + ".png");
    const fs::path gp = fig / (name + ".gp");
    OutFile g(gp);
    g << "# demfem snapshot series; re-plot with: gnuplot " << gp.filename().string() << "\n";
    g << "# series/p<k>.png (g<k>.png): the particles of panel k as an image, coloured by speed "
         "with the palette below (grey)\n";
    g << "cd " << quote(fs::absolute(dat).string()) << "\n";
    const bool bar_column = !one_box && kind != Kind::Loci; // Loci: no colour box
    const int canvas_w = pw * static_cast<int>(cols) + (bar_column ? kBarColumn : 0);
    const int canvas_h = ph * static_cast<int>(rows) + 40;
    g << fmt::format("set terminal pngcairo size {},{} enhanced font 'DejaVu Sans,10'\n", canvas_w,
                     canvas_h);
    g << "set output " << quote(fs::absolute(png).string()) << "\n";
    g << "set palette defined " << detail::kPaletteGnuplot << "\n";
    g << fmt::format("set cbrange [0:{}]\nset cblabel 'speed [m/s]'\n", vmax > 0 ? vmax : 1.0);
    g << "set key off\nset size ratio -1\n";
    g << fmt::format("set xrange [{}:{}]\nset yrange [{}:{}]\n", xmin, xmax, zmin, zmax);
    const std::string title = quote(fmt::format("{} — {}", what, scene.label()));
    // The panels' cells below the title (40 pixels), as `layout` divides them.
    const double top = 1.0 - 40.0 / canvas_h;
    const double cell_w = static_cast<double>(pw) / canvas_w;
    const double cell_h = top / static_cast<double>(rows);
    if (bar_column)
      g << fmt::format("set multiplot title {} noenhanced\n", title);
    else
      g << fmt::format("set multiplot layout {},{} title {} noenhanced\n", rows, cols, title);
    for (std::size_t k = 0; k < n; ++k) {
      g << fmt::format("set title 't = {:.3g} s' noenhanced\n", frames[k].time);
      if (bar_column)
        g << fmt::format("set origin {:.5f},{:.5f}\nset size ratio -1 {:.5f},{:.5f}\n",
                         static_cast<double>(k % cols) * cell_w,
                         top - static_cast<double>(k / cols + 1) * cell_h, cell_w, cell_h);
      std::string cl;
      const int pixmap = static_cast<int>(k) + 1;
      if (kind == Kind::Loci) {
        g << "unset colorbox\n";
        g << detail::raster_pixmap(grid, fmt::format("g{}.png", k), pixmap);
        cl = fmt::format("'l{}.dat' using 1:2 with lines lw 2 lc rgb '#c0392b'", k);
      } else {
        // the colour box: in the first empty cell, or over the middle 70 % of the bar column
        if (k + 1 < n) {
          g << "unset colorbox\n";
        } else if (one_box) {
          const auto slot_r = static_cast<double>(n / cols), slot_c = static_cast<double>(n % cols);
          g << fmt::format(
              "set colorbox user origin screen {:.4f},{:.4f} size screen {:.4f},{:.4f}\n",
              (slot_c + 0.12) * cell_w, top - (slot_r + 0.85) * cell_h, 0.06 * cell_w,
              0.65 * cell_h);
        } else {
          g << fmt::format(
              "set colorbox user origin screen {:.4f},{:.4f} size screen {:.4f},{:.4f}\n",
              (static_cast<double>(pw * static_cast<int>(cols)) + 20.0) / canvas_w, 0.15 * top,
              24.0 / canvas_w, 0.7 * top);
        }
        g << detail::raster_pixmap(grid, fmt::format("p{}.png", k), pixmap);
        cl = "NaN with lines lc palette frac 0"; // keeps the colour box
      }
      if (kind == Kind::Chains)
        for (int block = 0; block < 2 * kClasses; ++block) {
          const bool tension = block >= kClasses;
          const double lw = 0.3 + 2.5 * ((block % kClasses) + 1) / kClasses;
          cl += fmt::format(", 'c{}.dat' index {} using 1:2:3:4 with vectors nohead lw {:.2f} {} "
                            "lc rgb '{}'",
                            k, block, lw, tension ? "dt 2" : "", tension ? "#7b3294" : "#222222");
        }
      if (kind == Kind::Velocity)
        cl += fmt::format(", 'v{}.dat' using 1:2:3:4 with vectors head filled size screen "
                          "0.006,20 lw 1.5 lc rgb '#111111'",
                          k);
      cl += fmt::format(", 'b{}.dat' using 1:2 with lines lw 2 lc rgb '#000000'", k);
      g << "plot " << cl << "\n";
      g << fmt::format("unset pixmap {}\n", pixmap);
    }
    g << "unset multiplot\nset output\n";
    g.close();
    scripts.push_back(gp);
    pngs.push_back(png);
  };
  strip(Kind::Chains, "series_force_chains",
        fmt::format(
            "particles (colour = speed) and normal-force chains (width ∝ |f_n|, max "
            "{:.3g} N{})",
            fmax,
            chains_total > max_chains
                ? fmt::format("; the strongest {} of up to {} per panel", max_chains, chains_total)
                : std::string()));
  strip(Kind::Velocity, "series_velocity",
        fmt::format("velocity field: colour = particle speed (max {:.3g} m/s); arrows = mean "
                    "velocity of the particles in each {:.3g} m cell (longest {:.3g} m/s)",
                    vmax, vcell, vcell_max));
  strip(Kind::Loci, "series_loci", "loci of the traced particles up to each time");
  // The three strips are the slowest figures of a run (≈ 0.4 s each for the wall scene's 3,400
  // disks): one gnuplot per core.
  const auto errors = detail::run_gnuplot_scripts(scripts);
  for (std::size_t k = 0; k < scripts.size(); ++k)
    if (errors[k].empty())
      res.figures.push_back(pngs[k]);
    else
      res.problems.push_back(fmt::format("{}: {}", pngs[k].filename().string(), errors[k]));
  return res;
}

} // namespace demfem::compare
