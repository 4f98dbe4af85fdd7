// The particles' container: is the region the packing fills closed by walls and structures?
//
// The DEM holds particles only with walls and structures; the domain polygon is no barrier (a
// particle below every boundary leaves the scene, dem/src/engine_neighbours.cpp). While it
// deposits, the packing closes every fill edge that does not face upwards (outward normal's z ≤
// 0.5) with a temporary wall (dem/src/pack.cpp), and removes them when the run starts. So each such
// edge must be held when the run starts: by a wall or structure along it, or else by what a
// particle leaving through it meets. A particle leaving falls (gravity along −z), slides down any
// inclined wall or structure edge it lands on, and comes to rest in a valley (where a boundary
// rises again) or on a level one; if it falls past every boundary it is lost. An edge whose
// particles are lost is an error: the run would drain (a whole side open to nothing). An open
// edge whose particles land somewhere is accepted (a landslide's open front, cases/slope_ontake).
// Walls that open later (opens_at, open-wall events) count as closed: that opening is planned.
// Wall corners outside the domain (other than above it) are warnings: the domain is what the
// continuum meshes and the profiles span, but a wall reaching beyond it can be deliberate.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "validate_internal.hpp"

namespace demfem::scene::detail {

namespace {

struct Segment {
  Vec2 a, b;
  std::string owner; // "wall 'base'" / "structure 'pile'"
};

struct Trace {
  bool lost = false;
  std::string via; // the boundary it last slid on, when any
  Vec2 end;        // where it left that boundary (or was released, when none)
};

double dist(Vec2 q, const Segment& s) {
  return segment_distance(q, s.a, s.b);
}

// The highest boundary segment crossed by the vertical line through p below p (vertical segments
// and `skip` left out); the crossing height in `hz`.
const Segment* first_below(const std::vector<Segment>& segs, Vec2 p, const Segment* skip,
                           double tol, double& hz) {
  const Segment* best = nullptr;
  hz = -std::numeric_limits<double>::infinity();
  for (const auto& s : segs) {
    if (&s == skip) continue;
    const double x0 = std::min(s.a.x, s.b.x), x1 = std::max(s.a.x, s.b.x);
    if (x1 - x0 <= tol || p.x < x0 || p.x > x1) continue;
    const double z = s.a.z + (s.b.z - s.a.z) * (p.x - s.a.x) / (s.b.x - s.a.x);
    if (z <= p.z + tol && z > hz) {
      hz = z;
      best = &s;
    }
  }
  return best;
}

// Follows a particle released at p: falls, slides down inclined boundaries, stops in a valley or
// on a level boundary. `gap`: openings narrower than this hold every particle.
Trace follow(const std::vector<Segment>& segs, Vec2 p, double gap, double tol) {
  Trace t;
  const Segment* skip = nullptr;
  double dir = 0.0; // the way it slides along x (±1), 0 before the first slide
  for (int step = 0; step < 64; ++step) {
    double hz = 0.0;
    const Segment* s = first_below(segs, p, skip, tol, hz);
    if (!s) {
      t.lost = true;
      if (t.via.empty()) t.end = p;
      return t;
    }
    // slide down s (and down what continues it) to where it stops or leaves the boundaries
    for (int k = 0; k < 64; ++k) {
      if (std::abs(s->b.z - s->a.z) <= tol) return t; // level: it stays
      const Vec2 lo = s->a.z < s->b.z ? s->a : s->b;
      const Vec2 hi = s->a.z < s->b.z ? s->b : s->a;
      if (std::abs(lo.x - hi.x) > tol) dir = lo.x > hi.x ? 1.0 : -1.0;
      t.via = s->owner;
      const Segment* next = nullptr;
      for (const auto& o : segs) {
        if (&o == s || dist(lo, o) > gap) continue;
        const double od = std::max(o.a.z, o.b.z) - lo.z;
        const bool level = std::abs(o.b.z - o.a.z) <= tol;
        if (!level && od > tol) return t; // a boundary rises from here: a valley
        if (level) {
          const double far = dir >= 0.0 ? std::max(o.a.x, o.b.x) : std::min(o.a.x, o.b.x);
          if ((far - lo.x) * (dir >= 0.0 ? 1.0 : -1.0) > gap) return t; // a floor ahead
          continue;
        }
        if (std::min(o.a.z, o.b.z) < lo.z - tol) next = &o; // it goes on down along o
      }
      if (!next) { // a free lower end: it falls from there
        t.end = lo;
        p = {lo.x + dir * gap, lo.z};
        skip = s;
        break;
      }
      s = next;
    }
  }
  return t; // too long a path to follow: not called lost
}

} // namespace

void validate_container(const Scene& sc, const toml::table& root, const std::string& file,
                        std::vector<Diagnostic>& diags) {
  const Bounds db = bounds(sc.domain);
  const double size = std::hypot(db.x1 - db.x0, db.z1 - db.z0);
  const double tol = 1e-6 * size;

  // ---- wall corners outside the domain, other than above it (side walls taller than the
  // domain are common and harmless): warnings
  auto above_the_domain = [&](Vec2 q) {
    double top = -std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < sc.domain.size(); ++i) {
      const Vec2 a = sc.domain[i], b = sc.domain[(i + 1) % sc.domain.size()];
      if (q.x < std::min(a.x, b.x) - tol || q.x > std::max(a.x, b.x) + tol) continue;
      top =
          std::max(top, std::abs(b.x - a.x) <= tol ? std::max(a.z, b.z)
                                                   : a.z + (b.z - a.z) * (q.x - a.x) / (b.x - a.x));
    }
    return std::isfinite(top) && q.z > top;
  };
  for (std::size_t w = 0; w < sc.walls.size(); ++w) {
    const auto& pts = sc.walls[w].points;
    for (std::size_t k = 0; k < pts.size(); ++k) {
      const Vec2 q = pts[k];
      if (contains(sc.domain, q) || above_the_domain(q)) continue;
      double d = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < sc.domain.size(); ++i)
        d = std::min(d, segment_distance(q, sc.domain[i], sc.domain[(i + 1) % sc.domain.size()]));
      if (d <= tol) continue;
      const toml::node* n = root["wall"][w]["points"][k].node();
      if (!n) n = root["wall"][w]["points"].node();
      const auto& src = n ? n->source() : root.source();
      Diagnostic g;
      g.file = file;
      g.line = static_cast<int>(src.begin.line);
      g.column = static_cast<int>(src.begin.column);
      g.key = fmt::format("wall[{}].points[{}]", sc.walls[w].name, k);
      g.message =
          fmt::format("corner [{}, {}] lies {:.4g} m outside the domain [{}, {}] × [{}, {}] "
                      "m; particles can leave the scene through a gap it opens beside "
                      "the other boundaries",
                      q.x, q.z, d, db.x0, db.x1, db.z0, db.z1);
      g.warning = true;
      diags.push_back(std::move(g));
    }
  }

  // ---- the fill's container: packed particles under gravity only
  if (!sc.soil.dem || !sc.uses(Solver::Dem) || !sc.soil.dem->particles.empty() ||
      !(sc.load.gravity > 0.0))
    return;
  const auto& d = *sc.soil.dem;
  const Polygon& fill = d.fill.size() >= 3 ? d.fill : sc.domain;
  if (fill.size() < 3) return;
  double r_min = d.radius.min;
  if (d.radius.kind == RadiusDistribution::Kind::Table)
    for (const auto& [r, w] : d.radius.table)
      if (w > 0.0) r_min = std::min(r_min, r);
  if (!(r_min > 0.0)) return;
  std::vector<Segment> segs;
  for (const auto& w : sc.walls)
    for (std::size_t k = 0; k + 1 < w.points.size(); ++k)
      segs.push_back({w.points[k], w.points[k + 1], fmt::format("wall '{}'", w.name)});
  for (const auto& s : sc.structures)
    for (std::size_t k = 0; s.outline.size() >= 3 && k < s.outline.size(); ++k)
      segs.push_back({s.outline[k], s.outline[(k + 1) % s.outline.size()],
                      fmt::format("structure '{}'", s.name)});
  const bool fill_given = root["soil"]["dem"]["fill"].node() != nullptr;
  const toml::node* where =
      fill_given ? root["soil"]["dem"]["fill"].node() : root["domain"]["polygon"].node();
  const auto& src = where ? where->source() : root.source();
  const std::string key = fill_given ? "soil.dem.fill" : "domain.polygon";
  for (std::size_t k = 0; k < fill.size(); ++k) {
    const Vec2 a = fill[k], b = fill[(k + 1) % fill.size()];
    const double len = std::hypot(b.x - a.x, b.z - a.z);
    if (!(len > tol)) continue;
    const Vec2 n{(b.z - a.z) / len, -(b.x - a.x) / len}; // outward (counter-clockwise fill)
    if (n.z > 0.5) continue; // faces upwards: the packing leaves it open too
    // about one sample per smallest radius, at most 20,000 over the whole fill
    const double most = std::max(8.0, std::floor(20000.0 / static_cast<double>(fill.size())));
    const int samples = static_cast<int>(std::clamp(std::ceil(len / r_min), 8.0, most));
    std::optional<double> lost_from;
    double lost_to = 0.0;
    Trace first;
    for (int i = 0; i < samples; ++i) {
      const double f = (i + 0.5) / samples;
      const Vec2 q{a.x + f * (b.x - a.x), a.z + f * (b.z - a.z)};
      bool held = false;
      for (const auto& s : segs)
        if (dist(q, s) <= r_min) {
          held = true;
          break;
        }
      if (held) continue;
      const Trace t = follow(segs, {q.x + n.x * r_min, q.z + n.z * r_min}, 2.0 * r_min, tol);
      if (!t.lost) continue;
      if (!lost_from) {
        lost_from = f;
        first = t;
      }
      lost_to = f;
    }
    if (!lost_from) continue;
    const double f0 = std::max(0.0, *lost_from - 0.5 / samples);
    const double f1 = std::min(1.0, lost_to + 0.5 / samples);
    const Vec2 p0{a.x + f0 * (b.x - a.x), a.z + f0 * (b.z - a.z)};
    const Vec2 p1{a.x + f1 * (b.x - a.x), a.z + f1 * (b.z - a.z)};
    Diagnostic g;
    g.file = file;
    g.line = static_cast<int>(src.begin.line);
    g.column = static_cast<int>(src.begin.column);
    g.key = key;
    g.message = fmt::format(
        "the {} edge [{:.6g}, {:.6g}]–[{:.6g}, {:.6g}] of the region the particles fill{} is not "
        "closed from [{:.4g}, {:.4g}] to [{:.4g}, {:.4g}]: no wall or structure holds it, and "
        "particles leaving through it {}fall past every wall and structure (out of the scene); "
        "close it with a wall along it, e.g. [[wall]] points = [[{:.6g}, {:.6g}], [{:.6g}, "
        "{:.6g}]]",
        n.z < -0.5 ? "lower" : "side", a.x, a.z, b.x, b.z,
        fill_given ? " (soil.dem.fill)" : " (the domain polygon)", p0.x, p0.z, p1.x, p1.z,
        first.via.empty() ? std::string()
                          : fmt::format("slide down {} and off its end at [{:.4g}, {:.4g}], then ",
                                        first.via, first.end.x, first.end.z),
        a.x, a.z, b.x, b.z);
    diags.push_back(std::move(g));
  }
}

} // namespace demfem::scene::detail
