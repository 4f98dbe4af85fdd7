#include "demfem/dem/pack.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "demfem/dem/engine.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/scene/load.hpp"

namespace demfem::dem {

namespace fs = std::filesystem;

// ---- random numbers -----------------------------------------------------------------------------

PortableRandom::PortableRandom(std::uint64_t seed) : engine_(seed) {}

double PortableRandom::uniform() {
  return static_cast<double>(engine_() >> 11) * 0x1.0p-53; // 53 random bits → [0, 1)
}

double PortableRandom::uniform(double lo, double hi) {
  return lo + (hi - lo) * uniform();
}

std::vector<double> draw_radii(const scene::RadiusDistribution& d, int count, std::uint64_t seed) {
  PortableRandom rng(seed);
  std::vector<double> r(static_cast<std::size_t>(std::max(count, 0)));
  using K = scene::RadiusDistribution::Kind;
  std::vector<double> cdf;
  if (d.kind == K::Table) {
    double s = 0.0;
    for (const auto& [rad, w] : d.table) cdf.push_back(s += w);
    if (!(s > 0.0)) throw std::invalid_argument("radius table has no positive weight");
    for (auto& c : cdf) c /= s;
  }
  for (auto& ri : r) {
    switch (d.kind) {
    case K::Uniform:
      ri = rng.uniform(d.min, d.max);
      break; // uniform in r (paper Fig. 3.4)
    case K::Equal:
      ri = d.min;
      break;
    case K::Table: {
      const double u = rng.uniform();
      const auto it = std::upper_bound(cdf.begin(), cdf.end(), u);
      const auto k =
          std::min<std::size_t>(static_cast<std::size_t>(it - cdf.begin()), cdf.size() - 1);
      ri = d.table[k].first;
      break;
    }
    }
  }
  return r;
}

// ---- the cache key ------------------------------------------------------------------------------

namespace {

struct Fnv {
  std::uint64_t h = 0xcbf29ce484222325ull; // FNV-1a 64 offset basis
  void bytes(const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= b[i];
      h *= 0x100000001b3ull; // FNV-1a 64 prime
    }
  }
  void num(double v) {
    if (v == 0.0) v = 0.0; // −0 and +0 hash alike
    bytes(&v, sizeof v);
  }
  void integer(long long v) { bytes(&v, sizeof v); }
  void str(const std::string& s) {
    integer(static_cast<long long>(s.size()));
    bytes(s.data(), s.size());
  }
  void points(const std::vector<scene::Vec2>& p) {
    integer(static_cast<long long>(p.size()));
    for (const auto& q : p) {
      num(q.x);
      num(q.z);
    }
  }
};

constexpr int kPackingFormat = 1; // bump when the placement or deposition algorithm changes

} // namespace

std::string packing_key(const scene::Scene& scene) {
  Fnv f;
  f.integer(kPackingFormat);
  const auto& d = scene.soil.dem.value();
  f.points(d.fill);
  f.integer(d.count);
  f.integer(static_cast<int>(d.radius.kind));
  f.num(d.radius.min);
  f.num(d.radius.max);
  for (const auto& [r, w] : d.radius.table) {
    f.num(r);
    f.num(w);
  }
  f.num(d.density);
  f.num(d.thickness);
  f.integer(static_cast<int>(d.law));
  for (double v : {d.kn, d.ks, d.mu_static, d.mu_dynamic, d.rebound, d.rebound_speed,
                   d.tensile_strength, d.eta_n, d.eta_s, d.restitution, d.young, d.poisson,
                   d.damping_c, d.damping_d, d.dt, d.dt_safety})
    f.num(v);
  f.integer(d.tension ? 1 : 0);
  f.num(d.packing.ke_ratio);
  f.num(d.packing.max_time);
  f.num(d.packing.damping);
  f.num(scene.load.gravity);
  f.integer(static_cast<long long>(scene.info.seed));
  for (const auto& w : scene.walls) {
    f.str(w.name);
    f.points(w.points);
    f.num(w.mu_static.value_or(-1.0));
    f.num(w.mu_dynamic.value_or(-1.0));
  }
  for (const auto& s : scene.structures) {
    f.str(s.name);
    f.points(s.outline);
    f.num(s.mu_static.value_or(-1.0));
    f.num(s.mu_dynamic.value_or(-1.0));
  }
  return fmt::format("{:016x}", f.h);
}

fs::path packing_path(const scene::Scene& scene, const fs::path& out_dir) {
  const auto& d = scene.soil.dem.value();
  const fs::path dir = d.packing.cache.empty() ? out_dir / "packing" : fs::path(d.packing.cache);
  return dir / ("packing-" + packing_key(scene) + ".ckpt");
}

// ---- placement ----------------------------------------------------------------------------------

namespace {

[[noreturn]] void fill_error(const scene::Scene& scene, const std::string& message) {
  scene::Diagnostic diag;
  diag.file = scene.source_file;
  diag.key = "soil.dem.fill";
  diag.message = message;
  throw scene::SceneError({diag});
}

double seg_distance(scene::Vec2 p, scene::Vec2 a, scene::Vec2 b) {
  const double ex = b.x - a.x, ez = b.z - a.z, l2 = ex * ex + ez * ez;
  const double t =
      l2 > 0.0 ? std::clamp(((p.x - a.x) * ex + (p.z - a.z) * ez) / l2, 0.0, 1.0) : 0.0;
  return std::hypot(p.x - a.x - t * ex, p.z - a.z - t * ez);
}

double boundary_distance(const scene::Polygon& poly, scene::Vec2 p, bool closed) {
  double d = std::numeric_limits<double>::infinity();
  const std::size_t n = poly.size();
  const std::size_t m = closed ? n : (n == 0 ? 0 : n - 1);
  for (std::size_t k = 0; k < m; ++k) d = std::min(d, seg_distance(p, poly[k], poly[(k + 1) % n]));
  if (n == 1) d = std::hypot(p.x - poly[0].x, p.z - poly[0].z);
  return d;
}

struct Box {
  double x0, x1, z0, z1;
};

Box bbox(const scene::Polygon& p) {
  Box b{p[0].x, p[0].x, p[0].z, p[0].z};
  for (const auto& q : p) {
    b.x0 = std::min(b.x0, q.x);
    b.x1 = std::max(b.x1, q.x);
    b.z0 = std::min(b.z0, q.z);
    b.z1 = std::max(b.z1, q.z);
  }
  return b;
}

struct Placement {
  std::vector<double> x, z, r;
  int layers = 1;
  double top = 0.0; // highest site [m]
};

// Hexagonal lattice of pitch s = 2.1 r_max over the fill and copies of it stacked above; a site
// is used when its disk of radius s/2 lies inside the (shifted) fill, clear of walls and
// structures and not above a structure. Each particle sits at a random offset within the slack
// s/2 − r of its site, so neighbours never overlap.
Placement place(const scene::Scene& scene) {
  const auto& d = scene.soil.dem.value();
  const auto radii = draw_radii(d.radius, d.count, scene.info.seed);
  const double rmax = radii.empty() ? 0.0 : *std::max_element(radii.begin(), radii.end());
  const double s = 2.1 * rmax;
  const double half = 0.5 * s;
  const double row_h = s * std::sqrt(3.0) / 2.0; // hexagonal lattice row spacing
  const auto& F = d.fill;
  const Box fb = bbox(F);
  const double H = fb.z1 - fb.z0;
  std::vector<Box> sboxes;
  for (const auto& st : scene.structures) sboxes.push_back(bbox(st.outline));

  auto site_ok = [&](double x, double z) {
    const int k = std::max(0, static_cast<int>(std::floor((z - fb.z0) / H)));
    const scene::Vec2 q{x, z - k * H};
    if (!scene::contains(F, q) || boundary_distance(F, q, true) < half) return false;
    const scene::Vec2 p{x, z};
    for (const auto& w : scene.walls)
      if (boundary_distance(w.points, p, false) < half) return false;
    for (std::size_t i = 0; i < scene.structures.size(); ++i) {
      const auto& o = scene.structures[i].outline;
      if (scene::contains(o, p) || boundary_distance(o, p, true) < half) return false;
      // Not above a structure: it would land on it.
      if (x > sboxes[i].x0 - half && x < sboxes[i].x1 + half && z > sboxes[i].z0) return false;
    }
    return true;
  };

  Placement out;
  PortableRandom rng(scene.info.seed ^ 0x9e3779b97f4a7c15ull); // jitter stream, apart from radii
  const std::size_t need = radii.size();
  const int max_rows = 200000;
  for (int row = 0; row < max_rows && out.x.size() < need; ++row) {
    const double z = fb.z0 + half + row * row_h;
    const double shift = (row % 2) ? half : 0.0;
    for (double x = fb.x0 + half + shift; x <= fb.x1 - half + 1e-12 && out.x.size() < need;
         x += s) {
      if (!site_ok(x, z)) continue;
      const std::size_t i = out.x.size();
      const double slack = std::max(0.0, half - radii[i]) * 0.95;
      const double a = rng.uniform(0.0, 2.0 * 3.14159265358979323846);
      const double m = slack * std::sqrt(rng.uniform()); // uniform over the slack disk
      out.x.push_back(x + m * std::cos(a));
      out.z.push_back(z + m * std::sin(a));
      out.r.push_back(radii[i]);
      out.layers = std::max(out.layers, 1 + static_cast<int>(std::floor((z - fb.z0) / H)));
      out.top = std::max(out.top, z + half);
    }
    if (row > 50 && out.x.empty() && z > fb.z1 + 4 * H) break; // nothing fits anywhere
  }
  if (out.x.size() < need)
    fill_error(scene, fmt::format("only {} of {} particles (r_max = {} m) fit on a lattice in the "
                                  "fill polygon and copies of it stacked above; widen the fill",
                                  out.x.size(), need, rmax));
  return out;
}

bool on_boundary_of(const scene::Scene& scene, scene::Vec2 a, scene::Vec2 b, double tol) {
  const scene::Vec2 mid{0.5 * (a.x + b.x), 0.5 * (a.z + b.z)};
  auto covered = [&](const std::vector<scene::Vec2>& line, bool closed) {
    return boundary_distance(line, a, closed) < tol && boundary_distance(line, b, closed) < tol &&
           boundary_distance(line, mid, closed) < tol;
  };
  for (const auto& w : scene.walls)
    if (covered(w.points, false)) return true;
  for (const auto& s : scene.structures)
    if (covered(s.outline, true)) return true;
  return false;
}

void sort_by_id(Particles& p) {
  std::vector<std::uint32_t> order(p.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return p.id[a] < p.id[b]; });
  auto perm = [&](auto& v) {
    auto copy = v;
    for (std::size_t k = 0; k < order.size(); ++k) v[k] = copy[order[k]];
  };
  perm(p.x);
  perm(p.z);
  perm(p.phi);
  perm(p.vx);
  perm(p.vz);
  perm(p.omega);
  perm(p.fx);
  perm(p.fz);
  perm(p.torque);
  perm(p.radius);
  perm(p.mass);
  perm(p.inv_mass);
  perm(p.inv_inertia);
  perm(p.id);
  perm(p.material);
  perm(p.flags);
}

std::string stats_text(const PackResult& r) {
  return fmt::format("deposition_time={:.17g};steps={};ke_ratio={:.17g};converged={};layers={};"
                     "wall_seconds={:.17g}",
                     r.deposition_time, r.steps, r.ke_ratio, r.converged ? 1 : 0, r.layers,
                     r.wall_seconds);
}

void parse_stats(const std::string& s, PackResult& r) {
  std::istringstream in(s);
  std::string item;
  while (std::getline(in, item, ';')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) continue;
    const std::string k = item.substr(0, eq);
    const double v = std::strtod(item.c_str() + eq + 1, nullptr);
    if (k == "deposition_time")
      r.deposition_time = v;
    else if (k == "steps")
      r.steps = static_cast<long long>(v);
    else if (k == "ke_ratio")
      r.ke_ratio = v;
    else if (k == "converged")
      r.converged = v != 0.0;
    else if (k == "layers")
      r.layers = static_cast<int>(v);
    else if (k == "wall_seconds")
      r.wall_seconds = v;
  }
}

double top_of(const Particles& p) {
  double t = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < p.size(); ++i) t = std::max(t, p.z[i] + p.radius[i]);
  return t;
}

} // namespace

Particles place_particles(const scene::Scene& scene, int* layers) {
  const auto pl = place(scene);
  EngineConfig c = make_config(scene);
  Engine e(c);
  for (std::size_t i = 0; i < pl.x.size(); ++i) e.add_particle(pl.x[i], pl.z[i], pl.r[i]);
  if (layers) *layers = pl.layers;
  return e.particles();
}

PackResult pack(const scene::Scene& scene, const fs::path& out_dir,
                const scene::ProgressFn& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto& d = scene.soil.dem.value();
  const Placement pl = place(scene);

  EngineConfig c = make_config(scene);
  c.shaking = false; // deposition under gravity only
  if (d.packing.damping > 0.0) {
    // Deposition only: global viscous damping (eqs. 2.1, 2.2 with C = D per unit mass/inertia)
    // at ratio ζ = packing.damping of critical for the mean particle on one normal spring:
    // C = 2ζ√(K_n/m̄) (single-degree-of-freedom oscillator). It caps the fall speed at g/C.
    double m_mean = 0.0;
    for (double r : pl.r)
      m_mean += d.density * 3.14159265358979323846 * r * r * d.thickness; // m = ρπr²t
    m_mean /= static_cast<double>(std::max<std::size_t>(pl.r.size(), 1));
    const double extra = 2.0 * d.packing.damping * std::sqrt(d.kn / m_mean);
    c.damping_c += extra;
    c.damping_d += extra;
  }
  Engine e(c);
  for (std::size_t i = 0; i < pl.x.size(); ++i) e.add_particle(pl.x[i], pl.z[i], pl.r[i]);
  for (const auto& w : scene.walls) e.add_wall(w); // openings stay closed while depositing
  for (auto st : scene.structures) {               // fixed obstacles, unloaded
    st.dof_x = st.dof_z = st.dof_rotation = scene::DofMode::Fixed;
    st.force_x = st.force_z = st.moment = scene::TimeFunction{};
    st.motion_x = st.motion_z = st.motion_rotation = scene::TimeFunction{};
    e.add_structure(st);
  }
  // Temporary container: fill edges that do not face upwards and are not already a wall.
  const auto& F = d.fill;
  const Box fb = bbox(F);
  const double tol = 1e-6 * std::max(fb.x1 - fb.x0, fb.z1 - fb.z0);
  for (std::size_t k = 0; k < F.size(); ++k) {
    const auto a = F[k], b = F[(k + 1) % F.size()];
    const double len = std::hypot(b.x - a.x, b.z - a.z);
    const double nz =
        -(b.x - a.x) / len; // outward normal of a counter-clockwise polygon: (dz, −dx)/len
    if (nz > 0.5 || on_boundary_of(scene, a, b, tol)) continue;
    e.add_wall({a, b}, fmt::format("packing-container-{}", k));
  }
  if (pl.layers > 1) { // guides for the copies stacked above the fill
    e.add_wall({{fb.x0, fb.z1}, {fb.x0, pl.top + 2.0 * (fb.z1 - fb.z0)}}, "packing-guide-left");
    e.add_wall({{fb.x1, fb.z1}, {fb.x1, pl.top + 2.0 * (fb.z1 - fb.z0)}}, "packing-guide-right");
  }
  e.set_dt(d.dt > 0.0 ? d.dt : e.auto_dt());

  PackResult res;
  res.layers = pl.layers;
  const double g = scene.load.gravity;
  // Earliest stop: the time for the highest particle to fall to the bottom of the fill.
  // With damping the fall speed is capped at g/C, so the fall takes at least drop·C/g.
  const double drop = std::max(pl.top - fb.z0, 0.0);
  const double t_min = g > 0.0 ? std::max(std::sqrt(2.0 * drop / g), drop * c.damping_c / g) : 0.0;
  const long long chunk = 50;
  auto last_report = std::chrono::steady_clock::now();
  while (true) {
    e.run_steps(chunk);
    if (e.failed())
      throw std::runtime_error(fmt::format("packing of {} failed during deposition at t = {} s "
                                           "(Δt = {} s): {}",
                                           scene.label(), e.time(), e.dt(), e.failure()));
    const auto en = e.energy();
    const double ke = en.kinetic + en.rotational;
    res.ke_ratio = en.gravity_work > 0.0 ? ke / en.gravity_work : 1.0;
    if (e.time() >= t_min && res.ke_ratio < d.packing.ke_ratio) {
      res.converged = true;
      break;
    }
    if (e.time() >= d.packing.max_time) break;
    const auto now = std::chrono::steady_clock::now();
    if (progress && now - last_report > std::chrono::milliseconds(500)) {
      last_report = now;
      scene::Progress p;
      p.stage = "pack";
      p.time = e.time();
      p.end_time = d.packing.max_time;
      p.step = e.stats().steps;
      p.wall_seconds = std::chrono::duration<double>(now - t0).count();
      progress(p);
    }
  }
  res.deposition_time = e.time();
  res.steps = e.stats().steps;
  res.particles = e.particles();
  res.contact_history = e.save_contact_history(false);
  sort_by_id(res.particles);
  auto& P = res.particles;
  std::fill(P.vx.begin(), P.vx.end(), 0.0);
  std::fill(P.vz.begin(), P.vz.end(), 0.0);
  std::fill(P.omega.begin(), P.omega.end(), 0.0);
  std::fill(P.fx.begin(), P.fx.end(), 0.0);
  std::fill(P.fz.begin(), P.fz.end(), 0.0);
  std::fill(P.torque.begin(), P.torque.end(), 0.0);
  std::fill(P.phi.begin(), P.phi.end(), 0.0);
  std::fill(P.material.begin(), P.material.end(), std::uint16_t{0});
  res.surface_max = top_of(P);
  res.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  res.key = packing_key(scene);
  res.path = packing_path(scene, out_dir);
  fs::create_directories(res.path.parent_path());
  io::CheckpointMeta meta;
  meta.time = 0.0;
  meta.step = 0;
  meta.dt = e.dt();
  meta.label = "packing " + res.key + " " + scene.info.name;
  // extra: the statistics as text, a NUL byte, the contact history.
  const std::string text = stats_text(res);
  std::vector<std::byte> extra(reinterpret_cast<const std::byte*>(text.data()),
                               reinterpret_cast<const std::byte*>(text.data()) + text.size());
  extra.push_back(std::byte{0});
  extra.insert(extra.end(), res.contact_history.begin(), res.contact_history.end());
  io::write_checkpoint(res.path, P, meta, extra);
  try { // a picture of the packing beside the checkpoint, for ParaView
    fs::path vtp = res.path;
    vtp.replace_extension(".vtp");
    io::write_particles_vtp(vtp, P);
  } catch (const std::exception&) {
    // optional
  }
  return res;
}

PackResult pack_or_load(const scene::Scene& scene, const fs::path& out_dir,
                        const scene::ProgressFn& progress) {
  const auto& d = scene.soil.dem.value();
  if (!d.particles.empty()) { // explicit particles (verification scenes): no packing
    EngineConfig c = make_config(scene);
    Engine e(c);
    for (const auto& q : d.particles) e.add_particle(q[0], q[1], q[2], q[3], q[4], q[5]);
    PackResult r;
    r.particles = e.particles();
    r.converged = true;
    r.surface_max = top_of(r.particles);
    return r;
  }
  const fs::path path = packing_path(scene, out_dir);
  if (fs::exists(path)) {
    try {
      auto ck = io::read_checkpoint(path);
      const std::string label = "packing " + packing_key(scene) + " " + scene.info.name;
      if (ck.particles.size() == static_cast<std::size_t>(d.count) && ck.meta.label == label) {
        PackResult r;
        r.particles = std::move(ck.particles);
        r.path = path;
        r.key = packing_key(scene);
        r.from_cache = true;
        const auto nul = std::find(ck.extra.begin(), ck.extra.end(), std::byte{0});
        parse_stats(std::string(reinterpret_cast<const char*>(ck.extra.data()),
                                static_cast<std::size_t>(nul - ck.extra.begin())),
                    r);
        if (nul != ck.extra.end()) r.contact_history.assign(nul + 1, ck.extra.end());
        r.surface_max = top_of(r.particles);
        return r;
      }
    } catch (const io::IoError&) {
      // unreadable or stale: deposit again and overwrite
    }
  }
  return pack(scene, out_dir, progress);
}

} // namespace demfem::dem
