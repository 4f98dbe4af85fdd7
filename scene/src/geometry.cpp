#include <algorithm>
#include <cmath>

#include "demfem/scene/scene.hpp"

namespace demfem::scene {

// Shoelace formula: A = ½ Σ (x_i z_{i+1} − x_{i+1} z_i)
double signed_area(const Polygon& p) {
  double a = 0.0;
  for (std::size_t i = 0, n = p.size(); i < n; ++i) {
    const auto& u = p[i];
    const auto& v = p[(i + 1) % n];
    a += u.x * v.z - v.x * u.z;
  }
  return 0.5 * a;
}

namespace {
double cross(Vec2 o, Vec2 a, Vec2 b) {
  return (a.x - o.x) * (b.z - o.z) - (a.z - o.z) * (b.x - o.x);
}
bool on_segment(Vec2 p, Vec2 q, Vec2 r) {
  return std::min(p.x, r.x) <= q.x && q.x <= std::max(p.x, r.x) && std::min(p.z, r.z) <= q.z &&
         q.z <= std::max(p.z, r.z);
}
// Proper or touching intersection of segments p1p2 and p3p4 (orientation test).
bool segments_intersect(Vec2 p1, Vec2 p2, Vec2 p3, Vec2 p4) {
  const double d1 = cross(p3, p4, p1), d2 = cross(p3, p4, p2);
  const double d3 = cross(p1, p2, p3), d4 = cross(p1, p2, p4);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
    return true;
  if (d1 == 0 && on_segment(p3, p1, p4)) return true;
  if (d2 == 0 && on_segment(p3, p2, p4)) return true;
  if (d3 == 0 && on_segment(p1, p3, p2)) return true;
  if (d4 == 0 && on_segment(p1, p4, p2)) return true;
  return false;
}
} // namespace

bool self_intersects(const Polygon& p) {
  const std::size_t n = p.size();
  if (n < 4) return false;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      // skip adjacent edges (they share a vertex)
      if (j == i + 1 || (i == 0 && j == n - 1)) continue;
      if (segments_intersect(p[i], p[(i + 1) % n], p[j], p[(j + 1) % n])) return true;
    }
  }
  return false;
}

// Even–odd ray casting.
bool contains(const Polygon& p, Vec2 q) {
  bool in = false;
  for (std::size_t i = 0, n = p.size(), j = n - 1; i < n; j = i++) {
    if ((p[i].z > q.z) != (p[j].z > q.z) &&
        q.x < (p[j].x - p[i].x) * (q.z - p[i].z) / (p[j].z - p[i].z) + p[i].x)
      in = !in;
  }
  return in;
}

// Area centroid: C = 1/(6A) Σ (p_i + p_{i+1})(x_i z_{i+1} − x_{i+1} z_i)
Vec2 centroid(const Polygon& p) {
  const double a = signed_area(p);
  if (a == 0.0) return p.empty() ? Vec2{} : p.front();
  double cx = 0.0, cz = 0.0;
  for (std::size_t i = 0, n = p.size(); i < n; ++i) {
    const auto& u = p[i];
    const auto& v = p[(i + 1) % n];
    const double c = u.x * v.z - v.x * u.z;
    cx += (u.x + v.x) * c;
    cz += (u.z + v.z) * c;
  }
  return {cx / (6.0 * a), cz / (6.0 * a)};
}

Vec2 thrust_normal(const std::vector<Vec2>& outline, const Polygon& domain) {
  if (outline.size() < 2) return {1.0, 0.0};
  Vec2 a = outline.front(), b = outline.back();
  if (outline.size() > 2 && a.x == b.x && a.z == b.z) b = outline[1]; // closed: its first edge
  const double dx = b.x - a.x, dz = b.z - a.z, l = std::hypot(dx, dz);
  if (!(l > 0.0)) return {1.0, 0.0};
  Vec2 n{dz / l, -dx / l}; // right-hand normal of the chord
  if (domain.size() >= 3) {
    const Vec2 c = centroid(domain);
    const double side = (0.5 * (a.x + b.x) - c.x) * n.x + (0.5 * (a.z + b.z) - c.z) * n.z;
    if (side < 0.0) n = {-n.x, -n.z}; // point away from the soil
  }
  return n;
}

Bounds bounds(const std::vector<Vec2>& p) {
  Bounds b;
  if (p.empty()) return b;
  b.x0 = b.x1 = p[0].x;
  b.z0 = b.z1 = p[0].z;
  for (const auto& q : p) {
    b.x0 = std::min(b.x0, q.x);
    b.x1 = std::max(b.x1, q.x);
    b.z0 = std::min(b.z0, q.z);
    b.z1 = std::max(b.z1, q.z);
  }
  return b;
}

double segment_distance(Vec2 q, Vec2 a, Vec2 b) {
  const double ex = b.x - a.x, ez = b.z - a.z, l2 = ex * ex + ez * ez;
  const double t =
      l2 > 0.0 ? std::clamp(((q.x - a.x) * ex + (q.z - a.z) * ez) / l2, 0.0, 1.0) : 0.0;
  return std::hypot(q.x - a.x - t * ex, q.z - a.z - t * ez); // point–segment distance
}

Polygon clip(const Polygon& p, double a, double b, double c) {
  Polygon out;
  for (std::size_t k = 0; k < p.size(); ++k) {
    const Vec2 u = p[k], v = p[(k + 1) % p.size()];
    const double fu = a * u.x + b * u.z - c, fv = a * v.x + b * v.z - c;
    if (fu <= 0.0) out.push_back(u);
    if ((fu <= 0.0) != (fv <= 0.0)) {
      const double w = fu / (fu - fv);
      out.push_back({u.x + w * (v.x - u.x), u.z + w * (v.z - u.z)});
    }
  }
  return out;
}

Structure shifted(Structure st, double dz) {
  for (auto& q : st.outline) q.z += dz;
  st.base_centre.z += dz;
  st.pivot.z += dz;
  st.load_point.z += dz;
  return st;
}

Structure rotated(Structure st, double rot) {
  if (rot == 0.0) return st;
  const double c = std::cos(rot), s = std::sin(rot);
  const Vec2 o = st.pivot;
  auto turn = [&](Vec2& q) { // rigid rotation about the pivot, counter-clockwise positive
    const double lx = q.x - o.x, lz = q.z - o.z;
    q = {o.x + c * lx - s * lz, o.z + s * lx + c * lz};
  };
  for (auto& q : st.outline) turn(q);
  turn(st.base_centre);
  turn(st.load_point);
  return st;
}

} // namespace demfem::scene
