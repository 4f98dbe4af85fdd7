#include "demfem/scene/resources.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include <fmt/format.h>

namespace demfem::scene {

namespace {

// A number from a one-line file (cgroup v2: "max" or bytes); nothing when absent or "max".
std::optional<double> read_number_file(const char* path) {
  std::ifstream in(path);
  std::string word;
  if (!(in >> word) || word == "max") return std::nullopt;
  try {
    std::size_t used = 0;
    const double v = std::stod(word, &used);
    if (used != word.size() || !(v >= 0.0)) return std::nullopt;
    return v;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The cgroup (v2) this process runs in, from /proc/self/cgroup ("0::/path").
std::optional<std::string> cgroup_dir() {
  std::ifstream in("/proc/self/cgroup");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("0::", 0) == 0) return "/sys/fs/cgroup" + line.substr(3);
  return std::nullopt;
}

// Coarse steps through every break (sorted) of at most h each: continuum/run/run.cpp's
// steps_through, as cell boundaries (the first break included).
std::vector<double> uniform_nodes(const std::set<double>& breaks, double h) {
  std::vector<double> b(breaks.begin(), breaks.end()), nodes;
  if (b.empty()) return nodes;
  nodes.push_back(b.front());
  for (std::size_t i = 0; i + 1 < b.size(); ++i) {
    const double len = b[i + 1] - b[i];
    if (len <= 1e-9 * h) continue;
    const int n = std::max(1, static_cast<int>(std::ceil(len / h - 1e-9)));
    for (int k = 1; k <= n; ++k) nodes.push_back(nodes.back() + len / n);
  }
  return nodes;
}

// The cell size wanted at x: h(x) = min(h0, h_near + (g − 1)·d(x)), d the distance from
// [lo, hi] (cells growing geometrically by g away from the focus). Per interval between breaks,
// ∫ dx/h by the trapezoidal rule at m + 1 samples, and n = ⌈∫ dx/h⌉ cells.
struct Grading {
  double h0, h_near, g, lo, hi;
  static constexpr int m = 4000;
  [[nodiscard]] double h(double x) const {
    const double d = x < lo ? lo - x : (x > hi ? x - hi : 0.0);
    return std::min(h0, h_near + (g - 1.0) * d);
  }
  // cum[k] = ∫ dx/h from a to a + len·k/m
  [[nodiscard]] std::vector<double> integral(double a, double len) const {
    std::vector<double> cum(m + 1, 0.0);
    for (int k = 1; k <= m; ++k) {
      const double x0 = a + len * (k - 1) / m, x1 = a + len * k / m;
      cum[k] = cum[k - 1] + 0.5 * (1.0 / h(x0) + 1.0 / h(x1)) * (x1 - x0);
    }
    return cum;
  }
  [[nodiscard]] static double cells(const std::vector<double>& cum) {
    return std::max(1.0, std::ceil(cum[m] - 1e-9));
  }
};

// The graded grid's nodes (graded_steps_through summed from the first break).
std::vector<double> graded_nodes(const std::set<double>& breaks, double h0, double h_near, double g,
                                 double lo, double hi) {
  std::vector<double> nodes;
  if (breaks.empty()) return nodes;
  nodes.push_back(*breaks.begin());
  for (const double d : graded_steps_through(breaks, h0, h_near, g, lo, hi))
    nodes.push_back(nodes.back() + d);
  return nodes;
}

} // namespace

std::vector<double> graded_steps_through(const std::set<double>& breaks, double h0, double h_near,
                                         double g, double lo, double hi) {
  const Grading gr{h0, h_near, g, lo, hi};
  constexpr int m = Grading::m;
  std::vector<double> b(breaks.begin(), breaks.end()), out;
  for (std::size_t i = 0; i + 1 < b.size(); ++i) {
    const double len = b[i + 1] - b[i];
    if (len <= 1e-9 * h0) continue;
    const auto cum = gr.integral(b[i], len);
    const int n = static_cast<int>(Grading::cells(cum));
    double prev = b[i];
    int k = 0;
    for (int c = 1; c <= n; ++c) { // at equal increments of ∫ dx/h
      double x = b[i + 1];
      if (c < n) {
        const double target = cum[m] * c / n;
        while (k < m && cum[k + 1] < target) ++k;
        const double f = (target - cum[k]) / std::max(1e-300, cum[k + 1] - cum[k]);
        x = b[i] + len * (k + f) / m;
      }
      out.push_back(x - prev);
      prev = x;
    }
  }
  return out;
}

std::size_t graded_cell_count(const std::set<double>& breaks, double h0, double h_near, double g,
                              double lo, double hi) {
  const Grading gr{h0, h_near, g, lo, hi};
  std::vector<double> b(breaks.begin(), breaks.end());
  std::size_t count = 0;
  for (std::size_t i = 0; i + 1 < b.size(); ++i) {
    const double len = b[i + 1] - b[i];
    if (len <= 1e-9 * h0) continue;
    count += static_cast<std::size_t>(std::min(Grading::cells(gr.integral(b[i], len)), 1e15));
  }
  return count;
}

std::string format_bytes(double b) {
  const char* units[] = {"B", "KB", "MB", "GB", "TB", "PB", "EB"};
  int k = 0;
  while (b >= 1000.0 && k < 6) {
    b /= 1000.0;
    ++k;
  }
  return fmt::format("{:.3g} {}", b, units[k]);
}

std::optional<MemoryAvailable> available_memory() {
  std::optional<MemoryAvailable> out;
  {
    std::ifstream in("/proc/meminfo");
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("MemAvailable:", 0) == 0) {
        std::istringstream ss(line.substr(13));
        double kb = 0.0;
        if (ss >> kb && kb >= 0.0)
          out = MemoryAvailable{kb * 1024.0, "MemAvailable in /proc/meminfo"};
        break;
      }
  }
  if (const auto dir = cgroup_dir()) {
    const auto max = read_number_file((*dir + "/memory.max").c_str());
    const auto cur = read_number_file((*dir + "/memory.current").c_str());
    if (max && cur) {
      const double room = std::max(0.0, *max - *cur);
      if (!out || room < out->bytes)
        out = MemoryAvailable{room,
                              fmt::format("memory.max − memory.current of the cgroup {}", *dir)};
    }
  }
  return out;
}

ContinuumMeshEstimate estimate_continuum_mesh(const Scene& sc) {
  ContinuumMeshEstimate e;
  if (sc.domain.size() < 3) return e;
  const ContinuumOptions& co = sc.continuum;
  // the continuum soil: the domain below soil.continuum.surface when given
  Polygon soil = sc.domain;
  if (sc.soil.continuum && sc.soil.continuum->surface) {
    const Polygon below = clip(sc.domain, 0.0, 1.0, *sc.soil.continuum->surface);
    if (below.size() >= 3) soil = below;
  }
  std::set<double> xs, zs;
  double xmin = 1e300, xmax = -1e300, zmin = 1e300, zmax = -1e300;
  auto add = [&](const Vec2& p) {
    xs.insert(p.x);
    zs.insert(p.z);
    xmin = std::min(xmin, p.x);
    xmax = std::max(xmax, p.x);
    zmin = std::min(zmin, p.z);
    zmax = std::max(zmax, p.z);
  };
  for (const auto& p : sc.domain) add(p);
  for (const auto& p : soil) add(p);
  for (const auto& s : sc.structures)
    for (const auto& p : s.outline) add(p);
  const double h0 = std::min(xmax - xmin, zmax - zmin) / 4.0;
  if (!(h0 > 0.0)) return e;
  std::vector<double> nx, nz;
  constexpr double kListLimit = 1e6; // coarse cells tested one by one up to this many
  if (co.mesh_size_near > 0.0 && !sc.structures.empty()) {
    Bounds b = bounds(sc.structures.front().outline);
    for (const auto& s : sc.structures) {
      const Bounds c = bounds(s.outline);
      b = {std::min(b.x0, c.x0), std::max(b.x1, c.x1), std::min(b.z0, c.z0), std::max(b.z1, c.z1)};
    }
    const double hn = std::min(co.mesh_size_near, h0);
    e.columns = graded_cell_count(xs, h0, hn, co.mesh_grading, b.x0, b.x1);
    e.rows = graded_cell_count(zs, h0, hn, co.mesh_grading, b.z0, b.z1);
    if (static_cast<double>(e.columns) * static_cast<double>(e.rows) <= kListLimit) {
      nx = graded_nodes(xs, h0, hn, co.mesh_grading, b.x0, b.x1);
      nz = graded_nodes(zs, h0, hn, co.mesh_grading, b.z0, b.z1);
    }
  } else {
    nx = uniform_nodes(xs, h0);
    nz = uniform_nodes(zs, h0);
    e.columns = nx.empty() ? 0 : nx.size() - 1;
    e.rows = nz.empty() ? 0 : nz.size() - 1;
  }
  const double grid = static_cast<double>(e.columns) * static_cast<double>(e.rows);
  if (!nx.empty() && !nz.empty()) {
    for (std::size_t i = 0; i + 1 < nx.size(); ++i)
      for (std::size_t j = 0; j + 1 < nz.size(); ++j) {
        const Vec2 c{0.5 * (nx[i] + nx[i + 1]), 0.5 * (nz[j] + nz[j + 1])};
        bool meshed = contains(soil, c);
        for (std::size_t k = 0; !meshed && k < sc.structures.size(); ++k)
          meshed = sc.structures[k].outline.size() >= 3 && contains(sc.structures[k].outline, c);
        if (meshed) e.coarse_cells += 1.0;
      }
  } else { // too many to list: the soil's share of the grid's box
    const double box = (xmax - xmin) * (zmax - zmin);
    e.coarse_cells = box > 0.0 ? grid * std::min(1.0, std::abs(signed_area(soil)) / box) : grid;
  }
  const double split = std::pow(2.0, std::max(0, co.refinement)); // cells per coarse cell side
  const double p = std::max(1, co.degree);
  e.cells = e.coarse_cells * split * split;
  // FE_Q(p)² nodes: p² per cell plus a row and a column of them along the grid's sides
  const double sides = static_cast<double>(e.columns + e.rows) * split;
  e.dofs = e.coarse_cells > 0.0 ? 2.0 * (p * p * e.cells + p * sides + 1.0) : 0.0;
  e.bytes = kContinuumBaseBytes + e.dofs * kContinuumBytesPerDof;
  return e;
}

} // namespace demfem::scene
