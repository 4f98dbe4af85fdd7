// Semantic validation (issue 13): geometry inside the domain, structures clear of walls and of
// each other, particles that fit, distributions with weight, and step/memory/output ceilings.
#include "demfem/scene/validate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <fmt/format.h>

#include "validate_internal.hpp"

namespace demfem::scene {

namespace {

// The first `limit` particle pairs (i, j), j < i, in order of i then j, whose overlap
// r_i + r_j − |c_i − c_j| exceeds max_overlap·min(r_i, r_j) (the engine's blow-up check). A cell
// grid of size 2·r_max (sorted cell keys, candidates per cell by binary search): O(n log n), so
// particle files of any size are checked.
std::vector<std::pair<std::size_t, std::size_t>>
overlapping_pairs(const std::vector<std::array<double, 6>>& p, double max_overlap,
                  std::size_t limit) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  const std::size_t n = p.size();
  double x0 = INFINITY, z0 = INFINITY, rmax = 0.0;
  for (const auto& a : p)
    if (std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2])) {
      x0 = std::min(x0, a[0]);
      z0 = std::min(z0, a[1]);
      rmax = std::max(rmax, a[2]);
    }
  if (n < 2 || !(rmax > 0.0) || !std::isfinite(x0)) return out;
  const double h = 2.0 * rmax; // any touching pair is in the same or an adjacent cell
  auto cell = [&](const std::array<double, 6>& a) {
    return std::pair<std::int64_t, std::int64_t>{
        static_cast<std::int64_t>(std::min((a[0] - x0) / h, 1.0e15)),
        static_cast<std::int64_t>(std::min((a[1] - z0) / h, 1.0e15))};
  };
  std::vector<std::pair<std::pair<std::int64_t, std::int64_t>, std::size_t>> keyed;
  keyed.reserve(n);
  for (std::size_t i = 0; i < n; ++i)
    if (std::isfinite(p[i][0]) && std::isfinite(p[i][1]) && std::isfinite(p[i][2]))
      keyed.push_back({cell(p[i]), i});
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::size_t> cand;
  for (std::size_t i = 0; i < n && out.size() < limit; ++i) {
    const auto& a = p[i];
    if (!(std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2]))) continue;
    const auto [cx, cz] = cell(a);
    cand.clear();
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dz = -1; dz <= 1; ++dz) {
        const std::pair<std::int64_t, std::int64_t> c{cx + dx, cz + dz};
        auto lo = std::lower_bound(keyed.begin(), keyed.end(), std::pair{c, std::size_t{0}});
        for (; lo != keyed.end() && lo->first == c; ++lo)
          if (lo->second < i) cand.push_back(lo->second);
      }
    std::sort(cand.begin(), cand.end());
    for (const std::size_t j : cand) {
      const auto& b = p[j];
      const double ov = a[2] + b[2] - std::hypot(a[0] - b[0], a[1] - b[1]);
      if (ov > max_overlap * std::min(a[2], b[2])) {
        out.emplace_back(i, j);
        if (out.size() >= limit) break;
      }
    }
  }
  return out;
}

using Box = Bounds;
Box bbox(const std::vector<Vec2>& p) {
  return bounds(p);
}

double boundary_distance(const Polygon& p, Vec2 q) {
  double d = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0, n = p.size(); i < n; ++i)
    d = std::min(d, segment_distance(q, p[i], p[(i + 1) % n]));
  return d;
}

// Inside the closed polygon, with a tolerance on its boundary.
bool inside_closed(const Polygon& p, Vec2 q, double tol) {
  return contains(p, q) || boundary_distance(p, q) <= tol;
}
// Inside and further than tol from the boundary.
bool inside_strictly(const Polygon& p, Vec2 q, double tol) {
  return contains(p, q) && boundary_distance(p, q) > tol;
}

// Signed distance of q from the line through a and b (left positive).
double side(Vec2 a, Vec2 b, Vec2 q) {
  const double l = std::hypot(b.x - a.x, b.z - a.z);
  if (!(l > 0.0)) return 0.0;
  return ((b.x - a.x) * (q.z - a.z) - (b.z - a.z) * (q.x - a.x)) / l;
}
// The segments cross at a point interior to both (touching within tol does not count).
bool properly_cross(Vec2 a, Vec2 b, Vec2 c, Vec2 d, double tol) {
  const double d1 = side(c, d, a), d2 = side(c, d, b), d3 = side(a, b, c), d4 = side(a, b, d);
  return ((d1 > tol && d2 < -tol) || (d1 < -tol && d2 > tol)) &&
         ((d3 > tol && d4 < -tol) || (d3 < -tol && d4 > tol));
}

// The interiors of two polygons overlap (beyond tol).
bool interiors_overlap(const Polygon& a, const Polygon& b, double tol) {
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j)
      if (properly_cross(a[i], a[(i + 1) % a.size()], b[j], b[(j + 1) % b.size()], tol))
        return true;
  for (const auto& q : a)
    if (inside_strictly(b, q, tol)) return true;
  for (const auto& q : b)
    if (inside_strictly(a, q, tol)) return true;
  // Same outline (or every vertex on the other's boundary): compare centroids.
  return !a.empty() && !b.empty() && inside_strictly(b, centroid(a), tol) &&
         inside_strictly(a, centroid(b), tol);
}

// A polyline passes through the polygon's interior.
bool polyline_enters(const Polyline& w, const Polygon& p, double tol) {
  for (std::size_t i = 0; i + 1 < w.size(); ++i) {
    for (std::size_t j = 0; j < p.size(); ++j)
      if (properly_cross(w[i], w[i + 1], p[j], p[(j + 1) % p.size()], tol)) return true;
    const Vec2 mid{0.5 * (w[i].x + w[i + 1].x), 0.5 * (w[i].z + w[i + 1].z)};
    if (inside_strictly(p, mid, tol)) return true;
  }
  for (const auto& q : w)
    if (inside_strictly(p, q, tol)) return true;
  return false;
}

// The closed sets meet: a vertex of one in (or on) the other, or crossing edges.
bool touches_or_overlaps(const std::vector<Vec2>& a, bool a_closed, const Polygon& p, double tol) {
  for (const auto& q : a)
    if (inside_closed(p, q, tol)) return true;
  for (const auto& q : p)
    if (a_closed && a.size() >= 3 && inside_closed(a, q, tol)) return true;
  for (std::size_t i = 0; !a_closed && i + 1 < a.size(); ++i) // a corner of p on the polyline
    for (const auto& q : p)
      if (segment_distance(q, a[i], a[i + 1]) <= tol) return true;
  const std::size_t na = a_closed ? a.size() : (a.empty() ? 0 : a.size() - 1);
  for (std::size_t i = 0; i < na; ++i)
    for (std::size_t j = 0; j < p.size(); ++j)
      if (properly_cross(a[i], a[(i + 1) % a.size()], p[j], p[(j + 1) % p.size()], tol))
        return true;
  return false;
}

// E[r²] and the smallest drawn radius of a distribution (uniform in r: (a² + ab + b²)/3).
struct RadiusMoments {
  double mean_r2 = 0.0;
  double r_min = 0.0;
  double r_max = 0.0;
  double weight = 0.0; // table: Σ weights
};
RadiusMoments moments(const RadiusDistribution& d) {
  RadiusMoments m;
  using K = RadiusDistribution::Kind;
  switch (d.kind) {
  case K::Uniform:
    m.mean_r2 = (d.min * d.min + d.min * d.max + d.max * d.max) / 3.0;
    m.r_min = d.min;
    m.r_max = d.max;
    m.weight = 1.0;
    break;
  case K::Equal:
    m.mean_r2 = d.min * d.min;
    m.r_min = m.r_max = d.min;
    m.weight = 1.0;
    break;
  case K::Table: {
    double s = 0.0, s2 = 0.0;
    m.r_min = std::numeric_limits<double>::infinity();
    for (const auto& [r, w] : d.table) {
      if (!(w > 0.0)) continue;
      s += w;
      s2 += w * r * r;
      m.r_min = std::min(m.r_min, r);
      m.r_max = std::max(m.r_max, r);
    }
    m.weight = s;
    m.mean_r2 = s > 0.0 ? s2 / s : 0.0;
    if (!(s > 0.0)) m.r_min = 0.0;
    break;
  }
  }
  return m;
}

std::string human_bytes(double b) {
  const char* units[] = {"B", "KB", "MB", "GB", "TB", "PB", "EB"};
  int k = 0;
  while (b >= 1000.0 && k < 6) {
    b /= 1000.0;
    ++k;
  }
  return k == 6 && b >= 1000.0 ? fmt::format("{:.3g} EB", b)
                               : fmt::format("{:.3g} {}", b, units[k]);
}

} // namespace

std::string continuum_step_refusal(double dt, const ContinuumStepLimit& limit) {
  return fmt::format("time step {:.4g} s is above the explicit integrator's stable step {:.4g} s "
                     "({}); use dt ≤ {:.4g} s, or 0 for the automatic step, or integrator = "
                     "\"implicit\"",
                     dt, limit.dt, limit.formula, limit.dt);
}

Diagnostic continuum_step_diagnostic(const Scene& sc, const ContinuumStepLimit& limit) {
  Diagnostic d;
  d.file = sc.source_file;
  d.line = sc.continuum.dt_line;
  d.column = sc.continuum.dt_column;
  d.key = "continuum.dt";
  d.message = continuum_step_refusal(sc.continuum.dt, limit);
  return d;
}

std::string dem_step_refusal(double dt, const DemStepLimit& limit, double auto_dt) {
  return fmt::format("time step {:.4g} s is above the stable limit {:.4g} s ({}); use dt ≤ {:.4g} "
                     "s or 0 for automatic ({:.4g} s)",
                     dt, limit.dt, limit.formula, limit.dt, auto_dt);
}

Estimates estimate(const Scene& sc, const Vocabulary& vocabulary) {
  Estimates e;
  const double duration = sc.info.duration;
  if (sc.soil.dem) {
    const auto& d = *sc.soil.dem;
    const auto m = moments(d.radius);
    const double n = d.particles.empty() ? static_cast<double>(d.count)
                                         : static_cast<double>(d.particles.size());
    if (d.particles.empty()) {
      e.solid_area = n * std::numbers::pi * m.mean_r2;
    } else {
      for (const auto& q : d.particles) e.solid_area += std::numbers::pi * q[2] * q[2];
    }
    e.available_area = std::abs(signed_area(sc.domain));
    for (const auto& s : sc.structures) e.available_area -= std::abs(signed_area(s.outline));
    e.available_area = std::max(e.available_area, 0.0);
    e.packing_fraction = e.available_area > 0.0 ? e.solid_area / e.available_area
                                                : std::numeric_limits<double>::infinity();
    // Automatic Δt = dt_safety × the stable limit, from the DEM layer (the vocabulary's).
    if (vocabulary.dem_step_limit) e.dt_limit = vocabulary.dem_step_limit(sc);
    if (d.dt > 0.0) {
      e.dt = d.dt;
    } else if (e.dt_limit && std::isfinite(e.dt_limit->dt) && e.dt_limit->dt > 0.0) {
      e.dt = d.dt_safety * e.dt_limit->dt;
      e.dt_automatic = true;
    }
    if (e.dt && *e.dt > 0.0) {
      e.steps = duration / *e.dt;
      if (d.particles.empty()) e.packing_steps = d.packing.max_time / *e.dt;
    }
    e.memory_bytes = n * kBytesPerParticle;
    if (sc.output.vtk && sc.output.interval > 0.0) {
      e.snapshots = std::floor(duration / sc.output.interval) + 1.0;
      e.output_bytes = e.snapshots * n * kSnapshotBytesPerParticle;
    }
    if (sc.output.probe_interval > 0.0) {
      e.series_bytes = (duration / sc.output.probe_interval) * 25.0 * 12.0; // ~12 columns a row
      e.output_bytes += e.series_bytes;
    }
  }
  return e;
}

namespace detail {

namespace {

using Seg = std::variant<std::string_view, std::size_t>;

// Source position of the deepest existing node along path (falls back to the nearest parent).
toml::source_region locate(const toml::table& root, std::initializer_list<Seg> path) {
  const toml::node* cur = &root;
  toml::source_region best = root.source();
  for (const auto& s : path) {
    const toml::node* next = nullptr;
    if (const auto* k = std::get_if<std::string_view>(&s)) {
      if (const auto* t = cur->as_table()) next = t->get(*k);
    } else if (const auto* a = cur->as_array()) {
      const auto i = std::get<std::size_t>(s);
      if (i < a->size()) next = a->get(i);
    }
    if (!next) break;
    cur = next;
    if (next->source().begin.line > 0) best = next->source();
  }
  return best;
}

} // namespace

void validate_semantics(const Scene& sc, const toml::table& root, const std::string& file,
                        const Vocabulary& vocabulary, std::vector<Diagnostic>& diags) {
  auto add = [&](const toml::source_region& src, std::string key, std::string msg) {
    Diagnostic d;
    d.file = file;
    d.line = static_cast<int>(src.begin.line);
    d.column = static_cast<int>(src.begin.column);
    d.key = std::move(key);
    d.message = std::move(msg);
    diags.push_back(std::move(d));
  };
  if (sc.domain.size() < 3) return; // reported by the loader
  const Box db = bbox(sc.domain);
  const double size = std::hypot(db.x1 - db.x0, db.z1 - db.z0);
  const double tol = 1e-6 * size;
  const std::string dom =
      fmt::format("the domain [{}, {}] × [{}, {}] m", db.x0, db.x1, db.z0, db.z1);

  // ---- structures: in the domain, clear of walls and of each other -----------------------------
  auto structure_key = [&](std::size_t i) {
    const auto& s = sc.structures[i];
    const auto* t = root["structure"][i].as_table();
    const char* k = "base";
    if (t && !t->contains("base")) k = t->contains("polygon") ? "polygon" : "from";
    return std::pair{
        locate(root, {"structure", i, k}),
        fmt::format("structure[{}].{}", s.name.empty() ? std::to_string(i) : s.name, k)};
  };
  for (std::size_t i = 0; i < sc.structures.size(); ++i) {
    const auto& s = sc.structures[i];
    if (s.outline.size() < 3) continue;
    const auto [where, key] = structure_key(i);
    const Box b = bbox(s.outline);
    if (!touches_or_overlaps(s.outline, true, sc.domain, tol)) {
      add(where, key,
          fmt::format("structure '{}' ([{}, {}] × [{}, {}] m) lies outside {} and does not touch "
                      "it; move it so that at least its soil-facing side is in the domain",
                      s.name, b.x0, b.x1, b.z0, b.z1, dom));
      continue;
    }
    for (std::size_t w = 0; w < sc.walls.size(); ++w)
      if (polyline_enters(sc.walls[w].points, s.outline, tol))
        add(where, key,
            fmt::format("structure '{}' ([{}, {}] × [{}, {}] m) crosses wall '{}'; a structure "
                        "may touch a wall but not pass through it",
                        s.name, b.x0, b.x1, b.z0, b.z1, sc.walls[w].name));
    for (std::size_t j = 0; j < i; ++j)
      if (sc.structures[j].outline.size() >= 3 &&
          interiors_overlap(s.outline, sc.structures[j].outline, tol))
        add(where, key,
            fmt::format("structure '{}' overlaps structure '{}'; structures may touch but not "
                        "overlap",
                        s.name, sc.structures[j].name));
  }

  // ---- walls: meeting the (closed) domain -------------------------------------------------------
  for (std::size_t w = 0; w < sc.walls.size(); ++w) {
    const auto& wl = sc.walls[w];
    if (wl.points.size() >= 2 && !touches_or_overlaps(wl.points, false, sc.domain, tol)) {
      const Box b = bbox(wl.points);
      add(locate(root, {"wall", w, "points"}), fmt::format("wall[{}].points", wl.name),
          fmt::format("wall '{}' ([{}, {}] × [{}, {}] m) lies outside {} and does not touch it; "
                      "walls bound the soil inside the domain",
                      wl.name, b.x0, b.x1, b.z0, b.z1, dom));
    }
  }

  // ---- groups, probes: regions and points in the domain ----------------------------------------
  for (std::size_t p = 0; p < sc.probes.size(); ++p)
    for (std::size_t k = 0; k < sc.probes[p].points.size(); ++k)
      if (!inside_closed(sc.domain, sc.probes[p].points[k], tol)) {
        add(locate(root, {"probe", p, "points", k}), fmt::format("probe[{}].points[{}]", p, k),
            fmt::format("point [{}, {}] is outside {}", sc.probes[p].points[k].x,
                        sc.probes[p].points[k].z, dom));
        break;
      }

  // ---- memory: the continuum mesh and the particles against the machine's available memory
  const bool mesh_fits = validate_memory(sc, vocabulary, root, file, diags);

  // ---- continuum: an explicit step above the stable step (the run refuses the same)
  if (mesh_fits && vocabulary.continuum_step_limit && sc.soil.continuum &&
      sc.uses(Solver::Continuum) && sc.continuum.integrator == "explicit" && sc.continuum.dt > 0.0)
    if (const auto lim = vocabulary.continuum_step_limit(sc); lim && sc.continuum.dt > lim->dt)
      add(locate(root, {"continuum", "dt"}), "continuum.dt",
          continuum_step_refusal(sc.continuum.dt, *lim));

  if (!sc.soil.dem) return;
  const auto& d = *sc.soil.dem;

  // ---- radius distribution ---------------------------------------------------------------------
  const auto m = moments(d.radius);
  if (d.radius.kind == RadiusDistribution::Kind::Table && !d.radius.table.empty() &&
      !(m.weight > 0.0)) {
    add(locate(root, {"soil", "dem", "radius", "table"}), "soil.dem.radius.table",
        "every weight is 0: no radius can be drawn; give at least one entry [radius, weight] a "
        "weight > 0");
    return;
  }
  if (m.r_max > 0.0 && (2.0 * m.r_max > db.x1 - db.x0 || 2.0 * m.r_max > db.z1 - db.z0)) {
    add(locate(root, {"soil", "dem", "radius"}), "soil.dem.radius",
        fmt::format("the largest radius {} m does not fit {} (diameter {} m)", m.r_max, dom,
                    2.0 * m.r_max));
    return;
  }

  // ---- fill polygon inside the domain ----------------------------------------------------------
  if (const auto* ft = root["soil"]["dem"]["fill"].node(); ft && d.fill.size() >= 3) {
    for (std::size_t k = 0; k < d.fill.size(); ++k)
      if (!inside_closed(sc.domain, d.fill[k], tol)) {
        add(locate(root, {"soil", "dem", "fill"}), "soil.dem.fill",
            fmt::format("corner [{}, {}] is outside {}; the fill must lie in the domain",
                        d.fill[k].x, d.fill[k].z, dom));
        break;
      }
  }
  validate_container(sc, root, file, diags); // walls and structures hold the fill

  // ---- explicit particles ----------------------------------------------------------------------
  for (std::size_t i = 0; i < d.particles.size(); ++i) {
    const Vec2 c{d.particles[i][0], d.particles[i][1]};
    const auto where = locate(root, {"soil", "dem", "particles", i});
    const std::string key = fmt::format("soil.dem.particles[{}]", i);
    if (!inside_closed(sc.domain, c, tol)) {
      add(where, key, fmt::format("particle centre [{}, {}] is outside {}", c.x, c.z, dom));
      continue;
    }
    for (const auto& s : sc.structures)
      if (s.outline.size() >= 3 && inside_strictly(s.outline, c, tol)) {
        add(where, key,
            fmt::format("particle centre [{}, {}] is inside structure '{}'", c.x, c.z, s.name));
        break;
      }
  }
  { // pairwise overlaps beyond the blow-up limit: the first five pairs (i, j < i) in that order
    const auto over = overlapping_pairs(d.particles, d.max_overlap, 5);
    for (const auto& [i, j] : over) {
      const auto& a = d.particles[i];
      const auto& b = d.particles[j];
      const double ov = a[2] + b[2] - std::hypot(a[0] - b[0], a[1] - b[1]);
      add(locate(root, {"soil", "dem", "particles", i}), fmt::format("soil.dem.particles[{}]", i),
          fmt::format("overlaps particle {} by {:.4g} m, beyond max_overlap = {} of the "
                      "smaller radius; the run would stop at its first step",
                      j, ov, d.max_overlap));
    }
  }

  // ---- capacity, steps, memory, output ---------------------------------------------------------
  const Estimates e = estimate(sc, vocabulary);
  const auto count_where = locate(root, {"soil", "dem", "count"});
  if (d.particles.empty() && e.solid_area > kMaxPackingFraction * e.available_area) {
    const double fit = kMaxPackingFraction * e.available_area / (std::numbers::pi * m.mean_r2);
    add(count_where, "soil.dem.count",
        fmt::format("{} particles (mean πr² = {:.4g} m²) need {:.4g} m² of solid, but {} "
                    "leaves {:.4g} m² beside the structures, and even the densest disk packing "
                    "({:.4f}, hexagonal) holds only {:.4g} m² there: at most about {:.0f} "
                    "particles fit (estimate {:.3g} × capacity)",
                    d.count, std::numbers::pi * m.mean_r2, e.solid_area, dom, e.available_area,
                    kMaxPackingFraction, kMaxPackingFraction * e.available_area, std::floor(fit),
                    e.solid_area / (kMaxPackingFraction * e.available_area)));
    return;
  }
  // Δt above the stable limit (the DEM engine refuses the same step; issue 11).
  if (d.dt > 0.0 && e.dt_limit && d.dt > e.dt_limit->dt)
    add(locate(root, {"soil", "dem", "dt"}), "soil.dem.dt",
        dem_step_refusal(d.dt, *e.dt_limit, d.dt_safety * e.dt_limit->dt));
  if (e.memory_bytes > kMaxMemoryBytes)
    add(count_where, "soil.dem.count",
        fmt::format("{:.0f} particles need about {} of memory ({} B each: state, neighbour "
                    "lists, contacts); the ceiling is {}",
                    e.memory_bytes / kBytesPerParticle, human_bytes(e.memory_bytes),
                    kBytesPerParticle, human_bytes(kMaxMemoryBytes)));
  bool too_long = false;
  if (e.dt && e.steps + e.packing_steps > kMaxSteps) {
    too_long = true;
    const bool dt_given = !e.dt_automatic;
    add(locate(root, {"scene", "duration"}), "scene.duration",
        fmt::format("duration = {:.6g} s at Δt = {:.4g} s ({}) is {:.4g} steps{}; the ceiling is "
                    "{:.0e} steps (at ~1e7 particle-steps/s for {} particles that is about {:.3g} "
                    "days); shorten the duration{}",
                    sc.info.duration, *e.dt,
                    dt_given ? "soil.dem.dt" : "automatic: dt_safety × the stable limit", e.steps,
                    e.packing_steps > 0.0
                        ? fmt::format(" plus up to {:.4g} for the deposition", e.packing_steps)
                        : std::string(),
                    kMaxSteps, e.memory_bytes / kBytesPerParticle,
                    (e.steps + e.packing_steps) *
                        std::max(1.0, e.memory_bytes / kBytesPerParticle) / 1e7 / 86400.0,
                    dt_given ? " or raise soil.dem.dt" : ""));
  }
  if (!too_long && e.output_bytes > kMaxOutputBytes && e.series_bytes > e.output_bytes / 2.0)
    add(root["output"]["probe_interval"].node() ? locate(root, {"output", "probe_interval"})
                                                : locate(root, {"scene", "duration"}),
        "output.probe_interval",
        fmt::format("time series every {} s over {:.6g} s ({:.4g} rows per file) would write "
                    "about {}; the ceiling is {}; raise output.probe_interval",
                    sc.output.probe_interval, sc.info.duration,
                    sc.info.duration / sc.output.probe_interval, human_bytes(e.output_bytes),
                    human_bytes(kMaxOutputBytes)));
  else if (!too_long && e.output_bytes > kMaxOutputBytes)
    add(root["output"]["interval"].node() ? locate(root, {"output", "interval"})
                                          : locate(root, {"scene", "duration"}),
        "output.interval",
        fmt::format("{:.4g} snapshots of {:.0f} particles every {} s over {:.6g} s would write "
                    "about {}; the ceiling is {}; raise output.interval or set output.vtk = false",
                    e.snapshots, e.memory_bytes / kBytesPerParticle, sc.output.interval,
                    sc.info.duration, human_bytes(e.output_bytes), human_bytes(kMaxOutputBytes)));
}

} // namespace detail
} // namespace demfem::scene
