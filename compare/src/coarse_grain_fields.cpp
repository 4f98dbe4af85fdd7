// Reading the solvers' snapshots back (VTK XML) and the report's coarse-grained field comparison.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <optional>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include <fmt/format.h>

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLUnstructuredGridReader.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include "demfem/compare/coarse_grain.hpp"
#include "demfem/compare/gnuplot_run.hpp"
#include "demfem/compare/out_file.hpp"
#include "demfem/output/contract.hpp"

namespace fs = std::filesystem;

namespace demfem::compare {
namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string attribute(const std::string& tag, const std::string& name) {
  const std::regex re(name + "=\"([^\"]*)\"");
  std::smatch m;
  return std::regex_search(tag, m, re) ? m[1].str() : std::string();
}

vtkDataArray* array_of(vtkPointData* pd, const char* name) {
  return pd ? pd->GetArray(name) : nullptr;
}

} // namespace

std::vector<PvdEntry> read_pvd_entries(const fs::path& pvd) {
  std::vector<PvdEntry> out;
  if (!fs::exists(pvd)) return out;
  const std::string text = slurp(pvd);
  std::size_t pos = 0;
  while ((pos = text.find("<DataSet", pos)) != std::string::npos) {
    const auto end = text.find('>', pos);
    if (end == std::string::npos) break;
    const std::string tag = text.substr(pos, end - pos);
    pos = end;
    const std::string ts = attribute(tag, "timestep"), file = attribute(tag, "file");
    if (ts.empty() || file.empty()) continue;
    try {
      out.push_back({std::stod(ts),
                     fs::path(file).is_absolute() ? fs::path(file) : pvd.parent_path() / file});
    } catch (const std::exception&) {
    }
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const PvdEntry& a, const PvdEntry& b) { return a.time < b.time; });
  return out;
}

ParticleSnapshot read_particles_vtp(const fs::path& vtp) {
  ParticleSnapshot s;
  vtkNew<vtkXMLPolyDataReader> r;
  r->SetFileName(vtp.string().c_str());
  r->Update();
  vtkPolyData* pd = r->GetOutput();
  if (!pd || !pd->GetPoints()) return s;
  const vtkIdType n = pd->GetNumberOfPoints();
  vtkDataArray* id = array_of(pd->GetPointData(), "id");
  vtkDataArray* rad = array_of(pd->GetPointData(), "radius");
  vtkDataArray* vel = array_of(pd->GetPointData(), "velocity");
  for (vtkIdType k = 0; k < n; ++k) {
    double x[3];
    pd->GetPoint(k, x);
    s.x.push_back(x[0]);
    s.z.push_back(x[1]);
    s.id.push_back(id ? static_cast<std::uint32_t>(id->GetTuple1(k))
                      : static_cast<std::uint32_t>(k));
    s.radius.push_back(rad ? rad->GetTuple1(k) : 0.0);
    s.vx.push_back(vel ? vel->GetComponent(k, 0) : 0.0);
    s.vz.push_back(vel ? vel->GetComponent(k, 1) : 0.0);
  }
  return s;
}

std::vector<CgContact> read_force_chains_vtp(const fs::path& vtp) {
  std::vector<CgContact> out;
  vtkNew<vtkXMLPolyDataReader> r;
  r->SetFileName(vtp.string().c_str());
  r->Update();
  vtkPolyData* pd = r->GetOutput();
  if (!pd || !pd->GetLines()) return out;
  vtkDataArray* fn = pd->GetCellData()->GetArray("normal_force");
  vtkDataArray* fs_ = pd->GetCellData()->GetArray("shear_force");
  vtkDataArray* bnd = pd->GetCellData()->GetArray("boundary");
  vtkNew<vtkIdList> ids;
  vtkCellArray* lines = pd->GetLines();
  lines->InitTraversal();
  vtkIdType cell = 0;
  while (lines->GetNextCell(ids)) {
    if (ids->GetNumberOfIds() == 2) {
      double a[3], b[3];
      pd->GetPoint(ids->GetId(0), a);
      pd->GetPoint(ids->GetId(1), b);
      const double dx = a[0] - b[0], dz = a[1] - b[1];
      const double d = std::hypot(dx, dz);
      if (d > 0.0) {
        const double nx = dx / d, nz = dz / d, tx = -nz, tz = nx;
        const double f_n = fn ? fn->GetTuple1(cell) : 0.0;
        const double f_s = fs_ ? fs_->GetTuple1(cell) : 0.0;
        // force on i (the line's first point) from j: fn·n + fs·t (paper eq. 2.15)
        const bool wall = bnd && bnd->GetTuple1(cell) >= 0.0;
        out.push_back({a[0], a[1], b[0], b[1], f_n * nx + f_s * tx, f_n * nz + f_s * tz, wall});
      }
    }
    ++cell;
  }
  return out;
}

const std::vector<double>* ContinuumSnapshot::get(const std::string& name) const {
  const auto it = data.find(name);
  return it == data.end() ? nullptr : &it->second;
}

ContinuumSnapshot read_continuum_vtu(const fs::path& file) {
  ContinuumSnapshot s;
  std::vector<fs::path> pieces;
  if (file.extension() == ".pvtu") {
    const std::string text = slurp(file);
    std::size_t pos = 0;
    while ((pos = text.find("<Piece", pos)) != std::string::npos) {
      const auto end = text.find('>', pos);
      const std::string src = attribute(text.substr(pos, end - pos), "Source");
      pos = end;
      if (!src.empty()) pieces.push_back(file.parent_path() / src);
    }
  } else {
    pieces.push_back(file);
  }
  for (const auto& piece : pieces) {
    if (!fs::exists(piece)) continue;
    vtkNew<vtkXMLUnstructuredGridReader> r;
    r->SetFileName(piece.string().c_str());
    r->Update();
    vtkUnstructuredGrid* g = r->GetOutput();
    if (!g || !g->GetPoints()) continue;
    const std::size_t base = s.x.size();
    const vtkIdType n = g->GetNumberOfPoints();
    for (vtkIdType k = 0; k < n; ++k) {
      double x[3];
      g->GetPoint(k, x);
      s.x.push_back(x[0]);
      s.z.push_back(x[1]);
    }
    vtkPointData* pd = g->GetPointData();
    for (int a = 0; a < pd->GetNumberOfArrays(); ++a) {
      vtkDataArray* arr = pd->GetArray(a);
      if (!arr || !arr->GetName()) continue;
      const std::string name = arr->GetName();
      const int nc = arr->GetNumberOfComponents();
      auto push = [&](const std::string& key, int comp) {
        auto& v = s.data[key];
        v.resize(base, std::nan(""));
        for (vtkIdType k = 0; k < n; ++k) v.push_back(arr->GetComponent(k, comp));
      };
      if (nc == 1) {
        push(name, 0);
      } else if (nc >= 2) {
        push(name + "_x", 0);
        push(name + "_z", 1);
      }
    }
    vtkCellData* cd = g->GetCellData(); // per-cell arrays, spread onto the cell's points
    for (int a = 0; a < cd->GetNumberOfArrays(); ++a) {
      vtkDataArray* arr = cd->GetArray(a);
      if (!arr || !arr->GetName() || arr->GetNumberOfComponents() != 1) continue;
      auto& v = s.data[arr->GetName()];
      v.resize(base + static_cast<std::size_t>(n), std::nan(""));
      vtkNew<vtkIdList> ids;
      for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c) {
        g->GetCellPoints(c, ids);
        for (vtkIdType q = 0; q < ids->GetNumberOfIds(); ++q)
          v[base + static_cast<std::size_t>(ids->GetId(q))] = arr->GetTuple1(c);
      }
    }
    vtkNew<vtkIdList> ids;
    for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c) {
      g->GetCellPoints(c, ids);
      std::vector<std::size_t> cell;
      for (vtkIdType q = 0; q < ids->GetNumberOfIds(); ++q)
        cell.push_back(base + static_cast<std::size_t>(ids->GetId(q)));
      s.cells.push_back(std::move(cell));
    }
    for (auto& [k, v] : s.data) v.resize(s.x.size(), std::nan(""));
  }
  return s;
}

namespace {
bool soil_point(const ContinuumSnapshot& s, std::size_t p) {
  const auto* mat = s.get("material");
  return !mat || (*mat)[p] < 0.5;
}
} // namespace

std::vector<double> continuum_surface(const ContinuumSnapshot& s, double x0, double x1, int bins) {
  // The top boundary: for each distinct x of the soil points, the highest reference z there and
  // its displaced height (mean over the coincident patch points), then linear interpolation at
  // the bin centres.
  const auto* uz = s.get("displacement_z");
  std::map<long long, std::pair<double, std::pair<double, int>>> top; // key(x) → z_ref, (Σz, n)
  auto key = [](double x) { return std::llround(x * 1e6); };
  for (std::size_t p = 0; p < s.x.size(); ++p) {
    if (!soil_point(s, p)) continue;
    auto it = top.find(key(s.x[p]));
    const double zd = s.z[p] + (uz ? (*uz)[p] : 0.0);
    if (it == top.end() || s.z[p] > it->second.first + 1e-9)
      top[key(s.x[p])] = {s.z[p], {zd, 1}};
    else if (s.z[p] > it->second.first - 1e-9) {
      it->second.second.first += zd;
      ++it->second.second.second;
    }
  }
  std::vector<double> xs, zs;
  for (const auto& [k, v] : top) {
    xs.push_back(static_cast<double>(k) * 1e-6);
    zs.push_back(v.second.first / v.second.second);
  }
  std::vector<double> out(static_cast<std::size_t>(bins), std::nan(""));
  if (xs.size() < 2) return out;
  for (int b = 0; b < bins; ++b) {
    const double x = x0 + (x1 - x0) * (b + 0.5) / bins;
    if (x < xs.front() || x > xs.back()) continue;
    const auto it = std::upper_bound(xs.begin(), xs.end(), x);
    const std::size_t k = std::min(xs.size() - 1, static_cast<std::size_t>(it - xs.begin()));
    const std::size_t j = k - 1;
    const double w = (x - xs[j]) / (xs[k] - xs[j]);
    out[static_cast<std::size_t>(b)] = zs[j] + w * (zs[k] - zs[j]); // linear interpolation
  }
  return out;
}

std::vector<double> dem_surface_settlement(const ParticleSnapshot& rest,
                                           const ParticleSnapshot& end, double x0, double x1,
                                           int bins) {
  const auto nb = static_cast<std::size_t>(std::max(bins, 0));
  std::vector<double> out(nb, std::nan(""));
  const std::size_t n = rest.x.size();
  if (nb == 0 || n == 0 || !(x1 > x0)) return out;
  auto bin_of = [&](double x) -> std::optional<std::size_t> {
    const double f = (x - x0) / (x1 - x0) * static_cast<double>(nb);
    if (!(f >= 0.0) || f >= static_cast<double>(nb)) return std::nullopt;
    return static_cast<std::size_t>(f);
  };
  double dsum = 0.0;
  for (std::size_t k = 0; k < n; ++k) dsum += 2.0 * rest.radius[k];
  const double layer = dsum / static_cast<double>(n); // one mean diameter
  std::vector<double> top(nb, -std::numeric_limits<double>::infinity());
  for (std::size_t k = 0; k < n; ++k)
    if (const auto b = bin_of(rest.x[k])) top[*b] = std::max(top[*b], rest.z[k] + rest.radius[k]);
  std::unordered_map<std::uint32_t, std::size_t> at_end;
  at_end.reserve(end.id.size());
  for (std::size_t k = 0; k < end.id.size(); ++k) at_end.emplace(end.id[k], k);
  std::vector<double> sum(nb, 0.0);
  std::vector<int> count(nb, 0);
  for (std::size_t k = 0; k < n; ++k) {
    const auto b = bin_of(rest.x[k]);
    if (!b || rest.z[k] + rest.radius[k] < top[*b] - layer) continue;
    const auto it = at_end.find(rest.id[k]);
    if (it == at_end.end()) continue; // left the scene
    sum[*b] += rest.z[k] - end.z[it->second];
    ++count[*b];
  }
  for (std::size_t b = 0; b < nb; ++b)
    if (count[b] > 0) out[b] = sum[b] / count[b];
  return out;
}

StrainRange continuum_strain_range(const ContinuumSnapshot& s, double limit) {
  StrainRange r;
  const auto* ev = s.get("volumetric_strain");
  const auto* ep = s.get("plastic_strain");
  for (const auto& cell : s.cells) {
    if (cell.size() < 3 || !soil_point(s, cell[0])) continue;
    double a = 0.0, cx = 0.0, cz = 0.0; // shoelace area and vertex mean
    for (std::size_t k = 0; k < cell.size(); ++k) {
      const std::size_t p = cell[k], q = cell[(k + 1) % cell.size()];
      a += 0.5 * (s.x[p] * s.z[q] - s.x[q] * s.z[p]);
      cx += s.x[p] / static_cast<double>(cell.size());
      cz += s.z[p] / static_cast<double>(cell.size());
    }
    a = std::abs(a);
    r.area += a;
    const double v = ev ? (*ev)[cell[0]] : 0.0, pl = ep ? (*ep)[cell[0]] : 0.0; // cell values
    if (std::isfinite(v) && std::abs(v) > std::abs(r.max_volumetric)) {
      r.max_volumetric = v;
      r.vol_x = cx;
      r.vol_z = cz;
    }
    if (std::isfinite(pl) && pl > r.max_plastic) {
      r.max_plastic = pl;
      r.plastic_x = cx;
      r.plastic_z = cz;
    }
    if ((std::isfinite(v) && std::abs(v) > limit) || (std::isfinite(pl) && pl > limit))
      r.area_beyond += a;
  }
  return r;
}

std::vector<double> sample_continuum(const ContinuumSnapshot& s, const Grid& grid,
                                     const std::string& name) {
  std::vector<double> out(grid.size(), std::nan(""));
  const auto* v = s.get(name);
  if (!v) return out;
  for (const auto& cell : s.cells) {
    if (cell.size() != 4 || !soil_point(s, cell[0])) continue;
    double xa = 1e300, xb = -1e300, za = 1e300, zb = -1e300;
    for (auto p : cell) {
      xa = std::min(xa, s.x[p]);
      xb = std::max(xb, s.x[p]);
      za = std::min(za, s.z[p]);
      zb = std::max(zb, s.z[p]);
    }
    if (xb <= xa || zb <= za) continue;
    // the four corners by position: (xa,za) (xb,za) (xb,zb) (xa,zb)
    double c[4] = {NAN, NAN, NAN, NAN};
    for (auto p : cell) {
      const bool right = s.x[p] > 0.5 * (xa + xb), up = s.z[p] > 0.5 * (za + zb);
      c[up ? (right ? 2 : 3) : (right ? 1 : 0)] = (*v)[p];
    }
    const int i0 = std::max(0, static_cast<int>(std::ceil((xa - grid.x0) / grid.h - 1e-9)));
    const int i1 =
        std::min(grid.nx - 1, static_cast<int>(std::floor((xb - grid.x0) / grid.h + 1e-9)));
    const int k0 = std::max(0, static_cast<int>(std::ceil((za - grid.z0) / grid.h - 1e-9)));
    const int k1 =
        std::min(grid.nz - 1, static_cast<int>(std::floor((zb - grid.z0) / grid.h + 1e-9)));
    for (int k = k0; k <= k1; ++k)
      for (int i = i0; i <= i1; ++i) {
        const double a = std::clamp((grid.x(i) - xa) / (xb - xa), 0.0, 1.0);
        const double b = std::clamp((grid.z(k) - za) / (zb - za), 0.0, 1.0);
        // bilinear interpolation on the rectangle
        out[grid.at(i, k)] =
            (1 - a) * (1 - b) * c[0] + a * (1 - b) * c[1] + a * b * c[2] + (1 - a) * b * c[3];
      }
  }
  return out;
}

std::size_t nearest_entry(const std::vector<PvdEntry>& e, double t) {
  std::size_t best = 0;
  for (std::size_t k = 0; k < e.size(); ++k)
    if (std::abs(e[k].time - t) < std::abs(e[best].time - t)) best = k;
  return best;
}

namespace {

// Three panels (DEM coarse-grained, continuum, continuum − DEM) as gnuplot images.
bool draw_field_panels(const Grid& g, const std::vector<double>& dem,
                       const std::vector<double>& cont, const std::string& title,
                       const std::string& unit, double scale, const fs::path& png,
                       std::string* err) {
  const fs::path dat = fs::path(png).replace_extension(".dat");
  {
    OutFile f(dat);
    f << "# x z dem continuum continuum-dem (scaled by " << scale << ")\n";
    for (int k = 0; k < g.nz; ++k) {
      for (int i = 0; i < g.nx; ++i) {
        const auto n = g.at(i, k);
        const double d = dem[n] * scale, c = cont[n] * scale;
        auto w = [](double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : "NaN"; };
        f << fmt::format("{:.6g} {:.6g} {} {} {}\n", g.x(i), g.z(k), w(d), w(c),
                         w(std::isfinite(d) && std::isfinite(c) ? c - d : NAN));
      }
      f << "\n";
    }
    f.close();
  }
  // common colour range for the two fields, symmetric one for the difference
  double lo = 1e300, hi = -1e300, dm = 0.0;
  for (std::size_t n = 0; n < g.size(); ++n) {
    for (double v : {dem[n] * scale, cont[n] * scale})
      if (std::isfinite(v)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    if (std::isfinite(dem[n]) && std::isfinite(cont[n]))
      dm = std::max(dm, std::abs((cont[n] - dem[n]) * scale));
  }
  if (lo > hi) {
    if (err) *err = "no finite values";
    return false;
  }
  if (hi <= lo) hi = lo + 1.0;
  if (dm <= 0.0) dm = 1.0;
  const double wx = g.h * (g.nx - 1), wz = g.h * (g.nz - 1);
  const int pw = 1500;
  const int ph = std::clamp(static_cast<int>(pw / 3.0 * wz / std::max(wx, 1e-9)) + 60, 240, 900);
  const fs::path gp = fs::path(png).replace_extension(".gp");
  {
    OutFile f(gp);
    f << "set terminal pngcairo size " << pw << "," << ph << " font 'sans,10'\n";
    f << "set output '" << png.string() << "'\n";
    f << "set datafile missing 'NaN'\nset size ratio -1\nunset key\n";
    f << fmt::format("hh = {:.6g}\n", 0.5 * g.h); // each node drawn as a filled h × h square
    std::string gtitle = title;                   // gnuplot enhanced text: σ_zz → σ_{zz}
    for (const char* sub : {"_zz", "_xx", "_x", "_vol"}) {
      const auto k = gtitle.find(sub);
      if (k != std::string::npos)
        gtitle.replace(k, std::string(sub).size(), "_{" + std::string(sub + 1) + "}");
    }
    f << "set multiplot layout 1,3 title '" << gtitle << "'\n";
    f << fmt::format("set cbrange [{:.6g}:{:.6g}]\nset palette rgbformulae 33,13,10\n", lo, hi);
    f << "set xlabel 'x [m]'\nset ylabel 'z [m]'\n";
    f << "set title 'DEM, coarse-grained [" << unit << "]'\n";
    f << "plot '" << dat.string()
      << "' using 1:2:(hh):(hh):3 with boxxyerror fs solid noborder "
         "lc palette\n";
    f << "set title 'continuum [" << unit << "]'\n";
    f << "plot '" << dat.string()
      << "' using 1:2:(hh):(hh):4 with boxxyerror fs solid noborder "
         "lc palette\n";
    f << fmt::format("set cbrange [{:.6g}:{:.6g}]\n", -dm, dm);
    f << "set palette defined (0 '#2166ac', 1 '#f7f7f7', 2 '#b2182b')\n";
    f << "set title 'continuum − DEM [" << unit << "]'\n";
    f << "plot '" << dat.string()
      << "' using 1:2:(hh):(hh):5 with boxxyerror fs solid noborder "
         "lc palette\n";
    f << "unset multiplot\n";
    f.close();
  }
  const auto r = detail::run_gnuplot_scripts({gp}, 1); // the plots' shared runner
  if (!r[0].empty() || !fs::exists(png)) {
    if (err) *err = r[0].empty() ? fmt::format("gnuplot wrote no {}", png.string()) : r[0];
    return false;
  }
  return true;
}

// Bilinear interpolation of a grid field at (x, z); NaN outside the grid or where a corner is
// NaN (masked: outside the granular material).
double grid_at(const Grid& g, const std::vector<double>& v, double x, double z) {
  const double fi = (x - g.x0) / g.h, fk = (z - g.z0) / g.h;
  if (!(fi >= 0.0 && fk >= 0.0 && fi <= g.nx - 1 && fk <= g.nz - 1)) return std::nan("");
  const int i = std::min(static_cast<int>(fi), g.nx - 2),
            k = std::min(static_cast<int>(fk), g.nz - 2);
  const double a = fi - i, b = fk - k;
  return (1 - a) * (1 - b) * v[g.at(i, k)] + a * (1 - b) * v[g.at(i + 1, k)] +
         (1 - a) * b * v[g.at(i, k + 1)] + a * b * v[g.at(i + 1, k + 1)];
}

// One field of the maps on the continuum's mesh: the continuum's own point values and the DEM's
// coarse-grained grid field, in SI units.
struct MeshField {
  std::string key;
  std::vector<double> continuum; // per mesh point (NaN where the continuum has no value)
  const std::vector<double>* dem_grid = nullptr;
};

// The continuum's mesh at rest (reference coordinates, its cells as VTK quads or polygons) with,
// per point, "continuum <key>", "DEM <key>" (interpolated from the kernel grid; NaN off the soil
// and outside the granular material) and "continuum - DEM <key>": both methods and their difference
// on one mesh in ParaView (issue 9 item 3). Written through the checked atomic write.
void write_fields_vtu(const fs::path& file, const ContinuumSnapshot& mesh, const Grid& g,
                      const std::vector<MeshField>& fields) {
  const std::size_t np = mesh.x.size();
  vtkNew<vtkUnstructuredGrid> ug;
  vtkNew<vtkPoints> pts;
  pts->SetDataTypeToDouble();
  pts->SetNumberOfPoints(static_cast<vtkIdType>(np));
  for (std::size_t k = 0; k < np; ++k)
    pts->SetPoint(static_cast<vtkIdType>(k), mesh.x[k], mesh.z[k], 0.0);
  ug->SetPoints(pts);
  ug->Allocate(static_cast<vtkIdType>(mesh.cells.size()));
  for (const auto& c : mesh.cells) {
    std::vector<vtkIdType> ids(c.begin(), c.end());
    ug->InsertNextCell(ids.size() == 4 ? VTK_QUAD : VTK_POLYGON, static_cast<vtkIdType>(ids.size()),
                       ids.data());
  }
  const double nan = std::nan("");
  for (const auto& f : fields) {
    vtkNew<vtkDoubleArray> c, d, diff;
    c->SetName(("continuum " + f.key).c_str());
    d->SetName(("DEM " + f.key).c_str());
    diff->SetName(("continuum - DEM " + f.key).c_str());
    for (auto* a : {c.Get(), d.Get(), diff.Get()}) a->SetNumberOfValues(static_cast<vtkIdType>(np));
    for (std::size_t k = 0; k < np; ++k) {
      const double cv = k < f.continuum.size() ? f.continuum[k] : nan;
      const double dv = soil_point(mesh, k) ? grid_at(g, *f.dem_grid, mesh.x[k], mesh.z[k]) : nan;
      const auto id = static_cast<vtkIdType>(k);
      c->SetValue(id, cv);
      d->SetValue(id, dv);
      diff->SetValue(id, cv - dv);
    }
    ug->GetPointData()->AddArray(c);
    ug->GetPointData()->AddArray(d);
    ug->GetPointData()->AddArray(diff);
  }
  vtkNew<vtkXMLUnstructuredGridWriter> w;
  w->SetInputData(ug);
  w->SetDataModeToBinary();
  w->WriteToOutputStringOn();
  if (!w->Write()) throw std::runtime_error("VTK could not encode " + file.string());
  OutFile out(file);
  out << w->GetOutputString();
  out.close();
}

} // namespace

FieldComparison compare_fields(const fs::path& run_dir, double rest_time, double density,
                               double width) {
  FieldComparison out;
  namespace dir = output::dir;
  namespace file = output::file;
  const auto dp = read_pvd_entries(run_dir / dir::dem / file::particles_pvd);
  const auto dc = read_pvd_entries(run_dir / dir::dem / file::force_chains_pvd);
  const auto cp = read_pvd_entries(run_dir / dir::continuum / file::continuum_pvd);
  if (dp.empty() || cp.empty()) {
    out.notes.push_back("no DEM particle snapshots or no continuum snapshots: no field maps");
    return out;
  }
  const std::size_t d_rest = nearest_entry(dp, rest_time), d_end = dp.size() - 1;
  const double t_end = std::min(dp.back().time, cp.back().time);
  const std::size_t d_end2 = nearest_entry(dp, t_end);
  (void)d_end;
  const std::size_t c_rest = nearest_entry(cp, dp[d_rest].time), c_end = nearest_entry(cp, t_end);
  out.rest_time = dp[d_rest].time;
  out.end_time = dp[d_end2].time;
  ParticleSnapshot rest, end;
  ContinuumSnapshot crest, cend;
  try {
    rest = read_particles_vtp(dp[d_rest].file);
    end = read_particles_vtp(dp[d_end2].file);
    crest = read_continuum_vtu(cp[c_rest].file);
    cend = read_continuum_vtu(cp[c_end].file);
  } catch (const std::exception& e) {
    out.notes.push_back(std::string("snapshots could not be read: ") + e.what());
    return out;
  }
  if (rest.x.empty() || crest.x.empty()) {
    out.notes.push_back("empty snapshots: no field maps");
    return out;
  }
  double rmean = 0.0;
  for (double r : rest.radius) rmean += r;
  rmean /= static_cast<double>(rest.radius.size());
  out.width = width > 0.0 ? width : 4.0 * rmean; // 2 mean diameters
  // grid over the box holding both models' soil
  double xa = 1e300, xb = -1e300, za = 1e300, zb = -1e300;
  for (std::size_t k = 0; k < crest.x.size(); ++k) {
    xa = std::min(xa, crest.x[k]);
    xb = std::max(xb, crest.x[k]);
    za = std::min(za, crest.z[k]);
    zb = std::max(zb, crest.z[k]);
  }
  for (std::size_t k = 0; k < rest.x.size(); ++k) zb = std::max(zb, rest.z[k] + rest.radius[k]);
  Grid g;
  g.h = 0.5 * out.width;
  g.x0 = xa;
  g.z0 = za;
  g.nx = std::max(2, static_cast<int>(std::floor((xb - xa) / g.h)) + 1);
  g.nz = std::max(2, static_cast<int>(std::floor((zb - za) / g.h)) + 1);
  // DEM at rest: stress (rest configuration); displacement end − rest on the rest configuration
  auto particles = [&](const ParticleSnapshot& s) {
    CgParticles p;
    p.x = s.x;
    p.z = s.z;
    p.vx = s.vx;
    p.vz = s.vz;
    for (double r : s.radius) p.mass.push_back(density * std::numbers::pi * r * r); // per metre
    return p;
  };
  std::vector<CgContact> chains_rest;
  if (!dc.empty()) chains_rest = read_force_chains_vtp(dc[nearest_entry(dc, out.rest_time)].file);
  CgParticles prest = particles(rest);
  {
    std::map<std::uint32_t, std::size_t> at_end;
    for (std::size_t k = 0; k < end.id.size(); ++k) at_end[end.id[k]] = k;
    prest.ux.assign(rest.x.size(), 0.0);
    prest.uz.assign(rest.x.size(), 0.0);
    std::vector<bool> keep(rest.x.size(), false);
    for (std::size_t k = 0; k < rest.id.size(); ++k) {
      const auto it = at_end.find(rest.id[k]);
      if (it == at_end.end()) continue;
      prest.ux[k] = end.x[it->second] - rest.x[k];
      prest.uz[k] = end.z[it->second] - rest.z[k];
      keep[k] = true;
    }
    (void)keep;
  }
  const CgFields f = coarse_grain(prest, chains_rest, g, out.width);
  // nodes outside the granular material: density below half the median of the occupied nodes
  std::vector<double> occ;
  for (double r : f.density)
    if (r > 0.0) occ.push_back(r);
  std::sort(occ.begin(), occ.end());
  const double rho_cut = occ.empty() ? 0.0 : 0.5 * occ[occ.size() / 2];
  auto masked = [&](std::vector<double> v) {
    for (std::size_t n = 0; n < v.size(); ++n)
      if (f.density[n] < rho_cut) v[n] = std::nan("");
    return v;
  };
  auto diff = [](const std::vector<double>& a, const std::vector<double>& b) {
    std::vector<double> o(a.size());
    for (std::size_t n = 0; n < a.size(); ++n) o[n] = a[n] - b[n];
    return o;
  };
  struct Field {
    std::string key, title, unit;
    double scale;
    std::vector<double> dem, cont;
  };
  std::vector<Field> fields;
  if (!chains_rest.empty()) {
    fields.push_back({"szz_rest",
                      fmt::format("vertical stress σ_zz at rest (t = {:.3g} s)", out.rest_time),
                      "kPa", 1e-3, masked(f.szz), sample_continuum(crest, g, "stress_zz")});
    fields.push_back({"sxx_rest",
                      fmt::format("horizontal stress σ_xx at rest (t = {:.3g} s)", out.rest_time),
                      "kPa", 1e-3, masked(f.sxx), sample_continuum(crest, g, "stress_xx")});
  } else {
    out.notes.push_back(dc.empty() ? "no DEM force-chain snapshot: no stress maps"
                                   : "no contacts in the DEM's force-chain snapshot at rest: no "
                                     "stress maps");
  }
  fields.push_back({"ux_inc",
                    fmt::format("horizontal displacement u_x, t = {:.3g} s − t = {:.3g} s",
                                out.end_time, out.rest_time),
                    "cm", 100.0, masked(f.ux),
                    diff(sample_continuum(cend, g, "displacement_x"),
                         sample_continuum(crest, g, "displacement_x"))});
  fields.push_back(
      {"vol_inc",
       fmt::format("volumetric strain ε_vol (expansion +), t = {:.3g} s − t = {:.3g} s",
                   out.end_time, out.rest_time),
       "%", 100.0, masked(f.vol),
       diff(sample_continuum(cend, g, "volumetric_strain"),
            sample_continuum(crest, g, "volumetric_strain"))});
  fs::create_directories(run_dir / "compare");
  {
    OutFile csv(run_dir / "compare" / "fields.csv");
    csv << "x [m],z [m]";
    for (const auto& fl : fields) csv << ",dem." << fl.key << ",continuum." << fl.key;
    csv << "\n";
    for (int k = 0; k < g.nz; ++k)
      for (int i = 0; i < g.nx; ++i) {
        const auto n = g.at(i, k);
        csv << fmt::format("{:.6g},{:.6g}", g.x(i), g.z(k));
        for (const auto& fl : fields) csv << fmt::format(",{:.6g},{:.6g}", fl.dem[n], fl.cont[n]);
        csv << "\n";
      }
    csv.close();
  }
  {
    // the continuum's own point values on its rest mesh (the end snapshot has the same points)
    const bool same_mesh = cend.x.size() == crest.x.size();
    auto at_rest = [&](const char* name) {
      const auto* v = crest.get(name);
      return v ? *v : std::vector<double>(crest.x.size(), std::nan(""));
    };
    auto increment = [&](const char* name) {
      std::vector<double> o(crest.x.size(), std::nan(""));
      const auto *a = cend.get(name), *b = crest.get(name);
      if (same_mesh && a && b)
        for (std::size_t k = 0; k < o.size(); ++k) o[k] = (*a)[k] - (*b)[k];
      return o;
    };
    std::vector<MeshField> mf;
    for (const auto& fl : fields) {
      MeshField m{fl.key, {}, &fl.dem};
      if (fl.key == "szz_rest")
        m.continuum = at_rest("stress_zz");
      else if (fl.key == "sxx_rest")
        m.continuum = at_rest("stress_xx");
      else if (fl.key == "ux_inc")
        m.continuum = increment("displacement_x");
      else if (fl.key == "vol_inc")
        m.continuum = increment("volumetric_strain");
      mf.push_back(std::move(m));
    }
    write_fields_vtu(run_dir / "compare" / "fields.vtu", crest, g, mf);
    out.notes.push_back(
        "ParaView: compare/fields.vtu is the continuum's mesh at rest with each field below from "
        "both methods and their difference (point arrays \"continuum <key>\", \"DEM <key>\", "
        "\"continuum - DEM <key>\"; keys szz_rest, sxx_rest [Pa], ux_inc [m], vol_inc [-]); "
        "compare/fields.csv has the same fields on the kernel grid.");
  }
  for (const auto& fl : fields) {
    FieldComparison::Summary sm;
    sm.field = fl.title + " [" + fl.unit + "]";
    double sd = 0, sc = 0, s2 = 0;
    std::size_t n = 0;
    for (std::size_t q = 0; q < g.size(); ++q)
      if (std::isfinite(fl.dem[q]) && std::isfinite(fl.cont[q])) {
        sd += fl.dem[q] * fl.scale;
        sc += fl.cont[q] * fl.scale;
        s2 += std::pow((fl.cont[q] - fl.dem[q]) * fl.scale, 2);
        ++n;
      }
    if (n) {
      sm.mean_dem = sd / n;
      sm.mean_continuum = sc / n;
      sm.rms_difference = std::sqrt(s2 / n);
    }
    out.summaries.push_back(sm);
    const fs::path png = run_dir / "compare" / ("fields_" + fl.key + ".png");
    std::string err;
    if (draw_field_panels(g, fl.dem, fl.cont, fl.title, fl.unit, fl.scale, png, &err))
      out.figures.push_back(fs::relative(png, run_dir).string());
    else
      out.notes.push_back(fl.key + ": " + err);
  }
  out.notes.push_back(fmt::format(
      "DEM coarse-grained with Lucy's kernel, support radius c = {:.3g} m (2 mean particle "
      "diameters), on a {} × {} grid of spacing {:.3g} m; DEM snapshots at t = {:.3g} s (rest) and "
      "{:.3g} s, continuum snapshots at t = {:.3g} s and {:.3g} s. Grid nodes where the DEM's "
      "coarse-grained density is below half its median are blank. Stress tension positive; {}",
      out.width, g.nx, g.nz, g.h, out.rest_time, out.end_time, cp[c_rest].time, cp[c_end].time,
      std::any_of(chains_rest.begin(), chains_rest.end(),
                  [](const CgContact& k) { return k.boundary; })
          ? "the DEM's stress includes the wall and base contacts (Weinhart et al. 2012: the line "
            "from each particle to its contact point), so it holds up to the boundaries."
          : "the DEM's stress omits the wall and base contacts (not in these force-chain files, "
            "written before they were), so it is low within c of a boundary."));
  return out;
}

} // namespace demfem::compare
