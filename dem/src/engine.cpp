#include "demfem/dem/engine.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "demfem/dem/stable_step.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/validate.hpp"
#include "state_bytes.hpp"

namespace demfem::dem {

namespace {

// Active pairs (owner i < partner j) with their contact history, stored as the CSR neighbour list
// (sorted by owner, then partner) that rebuild() merges with the new candidates.
void store_pairs_csr(std::size_t n, const std::vector<std::uint32_t>& pi,
                     const std::vector<std::uint32_t>& pj, const std::vector<ContactHistory>& ph,
                     std::vector<std::uint32_t>& start, std::vector<std::uint32_t>& partner,
                     std::vector<ContactHistory>& hist) {
  std::vector<std::uint32_t> ord(pi.size());
  std::iota(ord.begin(), ord.end(), 0u);
  std::sort(ord.begin(), ord.end(), [&](std::uint32_t x, std::uint32_t y) {
    return pi[x] != pi[y] ? pi[x] < pi[y] : pj[x] < pj[y];
  });
  start.assign(n + 1, 0);
  partner.resize(ord.size());
  hist.resize(ord.size());
  for (std::size_t k = 0; k < ord.size(); ++k) {
    ++start[pi[ord[k]] + 1];
    partner[k] = pj[ord[k]];
    hist[k] = ph[ord[k]];
  }
  for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
}

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kReorderFirstMin = 4096; // particles: reorder at the first rebuild

template <class T> void permute(std::vector<T>& v, const std::vector<std::uint32_t>& order) {
  std::vector<T> out(v.size());
  for (std::size_t k = 0; k < order.size(); ++k) out[k] = v[order[k]];
  v.swap(out);
}

// Interleaves the bits of x and z (Morton / Z-order key).
std::uint64_t morton(std::uint32_t x, std::uint32_t z) {
  auto spread = [](std::uint64_t v) {
    v &= 0xffffffffull;
    v = (v | (v << 16)) & 0x0000ffff0000ffffull;
    v = (v | (v << 8)) & 0x00ff00ff00ff00ffull;
    v = (v | (v << 4)) & 0x0f0f0f0f0f0f0f0full;
    v = (v | (v << 2)) & 0x3333333333333333ull;
    v = (v | (v << 1)) & 0x5555555555555555ull;
    return v;
  };
  return spread(x) | (spread(z) << 1);
}

} // namespace

EngineConfig make_config(const scene::Scene& scene) {
  EngineConfig c;
  if (!scene.soil.dem) return c;
  const auto& d = *scene.soil.dem;
  c.law = d.law;
  c.kn = d.kn;
  c.ks = d.ks;
  c.rebound = d.rebound;
  c.rebound_speed = d.rebound_speed;
  c.tension = d.tension;
  c.tensile_strength = d.tensile_strength;
  c.eta_n = d.eta_n;
  c.eta_s = d.eta_s;
  c.restitution = d.restitution;
  c.young = d.young;
  c.poisson = d.poisson;
  c.damping_c = d.damping_c;
  c.damping_d = d.damping_d;
  c.density = d.density;
  c.thickness = d.thickness;
  c.sphere_mass = d.sphere_mass;
  c.max_overlap = d.max_overlap;
  c.dt_safety = d.dt_safety;
  c.materials = {Material{d.mu_static, d.mu_dynamic}};
  c.gravity = scene.load.gravity;
  if (scene.load.shaking) {
    c.shaking = true;
    c.shaking_direction = scene.load.shaking->direction;
    c.shaking_acceleration = scene.load.shaking->acceleration;
  }
  return c;
}

Engine::Engine(EngineConfig config) : config_(std::move(config)) {
  if (config_.materials.empty()) config_.materials.push_back(Material{});
}

std::uint16_t Engine::add_material(Material m) {
  config_.materials.push_back(m);
  return static_cast<std::uint16_t>(config_.materials.size() - 1);
}

void Engine::compute_mass(std::uint32_t i) {
  const double r = p_.radius[i];
  if (config_.sphere_mass) {
    const double m = config_.density * 4.0 / 3.0 * kPi * r * r * r; // m = ρ(4/3)πr³ (sphere)
    p_.mass[i] = m;
    p_.inv_mass[i] = 1.0 / m;
    p_.inv_inertia[i] = 1.0 / (0.4 * m * r * r); // I = (2/5) m r² (solid sphere)
    return;
  }
  const double m = config_.density * kPi * r * r * config_.thickness; // m = ρπr²t (PFC2D)
  p_.mass[i] = m;
  p_.inv_mass[i] = 1.0 / m;
  p_.inv_inertia[i] = 1.0 / (0.5 * m * r * r); // I = ½ m r² (disk)
}

std::uint32_t Engine::add_particle(double x, double z, double r, double vx, double vz, double omega,
                                   std::uint16_t material) {
  const auto i = static_cast<std::uint32_t>(p_.size());
  p_.x.push_back(x);
  p_.z.push_back(z);
  p_.phi.push_back(0.0);
  p_.vx.push_back(vx);
  p_.vz.push_back(vz);
  p_.omega.push_back(omega);
  p_.fx.push_back(0.0);
  p_.fz.push_back(0.0);
  p_.torque.push_back(0.0);
  p_.radius.push_back(r);
  p_.mass.push_back(0.0);
  p_.inv_mass.push_back(0.0);
  p_.inv_inertia.push_back(0.0);
  p_.id.push_back(next_id_++);
  p_.material.push_back(material);
  p_.flags.push_back(kFlagNone);
  compute_mass(i);
  r_min_ = i == 0 ? r : std::min(r_min_, r);
  r_max_ = i == 0 ? r : std::max(r_max_, r);
  m_min_ = i == 0 ? p_.mass[i] : std::min(m_min_, p_.mass[i]);
  need_rebuild_ = true;
  return p_.id.back();
}

// A boundary's vertices appended to the vertex arrays (world = reference at creation) and its
// own friction when the scene gives one (default: the soil's, μ_D capped by μ_s).
Boundary Engine::new_boundary(const std::string& name, const std::vector<scene::Vec2>& points,
                              std::optional<double> mu_s, std::optional<double> mu_d) {
  Boundary b;
  b.name = name;
  b.first_vertex = static_cast<std::uint32_t>(bvx_.size());
  b.vertex_count = static_cast<std::uint32_t>(points.size());
  if (mu_s || mu_d) {
    b.own_friction = true;
    b.mu_s = mu_s.value_or(config_.materials[0].mu_s);
    b.mu_d = mu_d.value_or(std::min(b.mu_s, config_.materials[0].mu_d));
  }
  for (const auto& q : points) {
    bvx_.push_back(q.x);
    bvz_.push_back(q.z);
    bvx0_.push_back(q.x);
    bvz0_.push_back(q.z);
  }
  return b;
}

int Engine::add_wall(const std::vector<scene::Vec2>& points, const std::string& name,
                     const double* mu_s, const double* mu_d) {
  Boundary b = new_boundary(name, points, mu_s ? std::optional<double>(*mu_s) : std::nullopt,
                            mu_d ? std::optional<double>(*mu_d) : std::nullopt);
  const auto bi = static_cast<std::uint32_t>(boundaries_.size());
  // Segments, then vertices with their adjacent segments.
  const std::uint32_t n = b.vertex_count;
  const auto seg0 = static_cast<std::int32_t>(features_.size());
  const std::uint32_t nseg = n < 2 ? 0 : n - 1;
  for (std::uint32_t k = 0; k < nseg; ++k)
    features_.push_back({bi, b.first_vertex + k, b.first_vertex + k + 1});
  for (std::uint32_t k = 0; k < n; ++k) {
    Feature f{bi, b.first_vertex + k, b.first_vertex + k};
    if (k > 0) f.adj0 = seg0 + static_cast<std::int32_t>(k) - 1;
    if (k < nseg) f.adj1 = seg0 + static_cast<std::int32_t>(k);
    features_.push_back(f);
  }
  boundaries_.push_back(b);
  need_rebuild_ = true;
  return static_cast<int>(bi);
}

int Engine::add_wall(const scene::Wall& wall) {
  const double* ms = wall.mu_static ? &*wall.mu_static : nullptr;
  const double* md = wall.mu_dynamic ? &*wall.mu_dynamic : nullptr;
  return add_wall(wall.points, wall.name, ms, md);
}

int Engine::add_structure(const scene::Structure& s) {
  StructureState st;
  st.name = s.name;
  st.spec = s;
  st.px0 = s.pivot.x;
  st.pz0 = s.pivot.z;
  // Area, centroid and second moment about the pivot of the polygon (shoelace formulas).
  const auto& P = s.outline;
  double a2 = 0.0, cx = 0.0, cz = 0.0, j0 = 0.0;
  for (std::size_t k = 0; k < P.size(); ++k) {
    const double x0 = P[k].x - s.pivot.x, z0 = P[k].z - s.pivot.z;
    const double x1 = P[(k + 1) % P.size()].x - s.pivot.x, z1 = P[(k + 1) % P.size()].z - s.pivot.z;
    const double cr = x0 * z1 - x1 * z0;
    a2 += cr;
    cx += (x0 + x1) * cr;
    cz += (z0 + z1) * cr;
    j0 += (x0 * x0 + x0 * x1 + x1 * x1 + z0 * z0 + z0 * z1 + z1 * z1) * cr; // polar moment ×12
  }
  const double area = 0.5 * std::abs(a2);
  st.cx_local = a2 != 0.0 ? cx / (3.0 * a2) : 0.0;
  st.cz_local = a2 != 0.0 ? cz / (3.0 * a2) : 0.0;
  const double rho_t = s.density * config_.thickness;
  st.mass = s.mass > 0.0 ? s.mass : rho_t * area;
  const double polar = std::abs(j0) / 12.0; // ∫(x²+z²) dA about the pivot
  st.inertia = s.inertia > 0.0 ? s.inertia : (area > 0.0 ? st.mass / area * polar : 0.0);

  // Outline as a closed boundary with one-sided (outward) edges.
  Boundary b = new_boundary(s.name, P, s.mu_static, s.mu_dynamic);
  b.closed = true;
  b.structure = static_cast<int>(structures_.size());
  const auto bi = static_cast<std::uint32_t>(boundaries_.size());
  const std::uint32_t n = b.vertex_count;
  const auto seg0 = static_cast<std::int32_t>(features_.size());
  for (std::uint32_t k = 0; k < n; ++k)
    features_.push_back({bi, b.first_vertex + k, b.first_vertex + (k + 1) % n});
  for (std::uint32_t k = 0; k < n; ++k) {
    Feature f{bi, b.first_vertex + k, b.first_vertex + k};
    f.adj0 = seg0 + static_cast<std::int32_t>((k + n - 1) % n);
    f.adj1 = seg0 + static_cast<std::int32_t>(k);
    features_.push_back(f);
  }
  st.first_vertex = b.first_vertex;
  st.vertex_count = n;
  st.boundary = bi;
  boundaries_.push_back(b);
  structures_.push_back(st);
  need_rebuild_ = true;
  return static_cast<int>(structures_.size() - 1);
}

int Engine::boundary_index(const std::string& name) const {
  for (std::size_t b = 0; b < boundaries_.size(); ++b)
    if (boundaries_[b].name == name) return static_cast<int>(b);
  return -1;
}

int Engine::structure_index(const std::string& name) const {
  for (std::size_t s = 0; s < structures_.size(); ++s)
    if (structures_[s].name == name) return static_cast<int>(s);
  return -1;
}

long Engine::index_of(std::uint32_t id) const {
  for (std::size_t i = 0; i < p_.size(); ++i)
    if (p_.id[i] == id) return static_cast<long>(i);
  return -1;
}

// ---- time step ----------------------------------------------------------------------------------

double Engine::stable_dt() const {
  if (p_.size() == 0) return std::numeric_limits<double>::infinity();
  // Pair reduced mass, shear–rotation mode, coordination margin, damping (stable_step.cpp).
  return critical_step(step_params(config_, m_min_, r_min_)).dt;
}

void Engine::set_dt(double dt) {
  const double lim = stable_dt();
  if (!(dt > 0.0) || dt > lim) {
    scene::Diagnostic d;
    d.key = "soil.dem.dt";
    d.message = scene::dem_step_refusal(
        dt, {lim, critical_step(step_params(config_, m_min_, r_min_)).formula()}, auto_dt());
    throw scene::SceneError({d});
  }
  dt_ = dt;
}

// ---- neighbour search ---------------------------------------------------------------------------

void Engine::update_boundary_vertices() {
  for (auto& st : structures_) {
    if (!(st.ux != 0.0 || st.uz != 0.0 || st.rot != 0.0 || st.vx != 0.0 || st.vz != 0.0 ||
          st.omega != 0.0))
      continue;
    const double c = std::cos(st.rot), s = std::sin(st.rot);
    const double px = st.px0 + st.ux, pz = st.pz0 + st.uz;
    for (std::uint32_t k = st.first_vertex; k < st.first_vertex + st.vertex_count; ++k) {
      const double lx = bvx0_[k] - st.px0, lz = bvz0_[k] - st.pz0;
      bvx_[k] = px + c * lx - s * lz; // rigid rotation about the pivot
      bvz_[k] = pz + s * lx + c * lz;
    }
  }
}

void Engine::check_rebuild() {
  if (need_rebuild_ || x_ref_.size() != p_.size()) {
    rebuild();
    return;
  }
  const double lim2 = 0.25 * skin_ * skin_;
  double m2 = 0.0;
  const std::size_t n = p_.size();
  const double* x = p_.x.data();
  const double* z = p_.z.data();
  const double* xr = x_ref_.data();
  const double* zr = z_ref_.data();
  const int A = team_size();
  if (A > 1) { // a max is exact in any order
#pragma omp parallel for num_threads(A) schedule(static) reduction(max : m2)
    for (std::size_t i = 0; i < n; ++i) {
      const double dx = x[i] - xr[i], dz = z[i] - zr[i];
      m2 = std::max(m2, dx * dx + dz * dz);
    }
  } else {
    for (std::size_t i = 0; i < n; ++i) {
      const double dx = x[i] - xr[i], dz = z[i] - zr[i];
      m2 = std::max(m2, dx * dx + dz * dz);
    }
  }
  double b2 = 0.0;
  for (std::size_t k = 0; k < bvx_.size(); ++k) {
    const double dx = bvx_[k] - bvx_ref_[k], dz = bvz_[k] - bvz_ref_[k];
    b2 = std::max(b2, dx * dx + dz * dz);
  }
  // A pair's gap changes by at most the sum of both displacements; both are < skin/2.
  if (m2 > lim2 || b2 > lim2) rebuild();
}

void Engine::reorder() {
  const std::size_t n = p_.size();
  if (n < 2) return;
  double xmin = p_.x[0], zmin = p_.z[0];
  for (std::size_t i = 0; i < n; ++i) {
    xmin = std::min(xmin, p_.x[i]);
    zmin = std::min(zmin, p_.z[i]);
  }
  const double h = 2.0 * r_max_;
  std::vector<std::uint64_t> key(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(p_.x[i]) || !std::isfinite(p_.z[i])) {
      key[i] = ~0ull;
      continue;
    }
    const auto cx = static_cast<std::uint32_t>(std::min((p_.x[i] - xmin) / h, 1.0e9));
    const auto cz = static_cast<std::uint32_t>(std::min((p_.z[i] - zmin) / h, 1.0e9));
    key[i] = morton(cx, cz);
  }
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });
  // Old index → new index, to carry the contact history over.
  std::vector<std::uint32_t> new_of(n);
  for (std::size_t k = 0; k < n; ++k) new_of[order[k]] = static_cast<std::uint32_t>(k);
  // Re-key the pair history: (owner, partner) → new indices, owner < partner.
  std::vector<std::uint32_t> pi, pj;
  std::vector<ContactHistory> ph;
  for (std::size_t i = 0; i + 1 < nbr_start_.size(); ++i)
    for (std::uint32_t k = nbr_start_[i]; k < nbr_start_[i + 1]; ++k)
      if (nbr_hist_[k].flags != 0) {
        // Swapping the owner flips both n and t, so f_t (force on the owner along t) is unchanged.
        std::uint32_t a = new_of[i], b = new_of[nbr_j_[k]];
        if (a > b) std::swap(a, b);
        pi.push_back(a);
        pj.push_back(b);
        ph.push_back(nbr_hist_[k]);
      }
  // Store as a CSR list holding only the active pairs; rebuild() merges it.
  store_pairs_csr(n, pi, pj, ph, nbr_start_, nbr_j_, nbr_hist_);
  for (auto& bi : bnd_i_) bi = new_of[bi];
  {
    std::vector<std::uint32_t> o(bnd_i_.size());
    std::iota(o.begin(), o.end(), 0u);
    std::sort(o.begin(), o.end(), [&](std::uint32_t a, std::uint32_t b) {
      return bnd_i_[a] != bnd_i_[b] ? bnd_i_[a] < bnd_i_[b] : bnd_f_[a] < bnd_f_[b];
    });
    permute(bnd_i_, o);
    permute(bnd_f_, o);
    permute(bnd_hist_, o);
  }
  permute(p_.x, order);
  permute(p_.z, order);
  permute(p_.phi, order);
  permute(p_.vx, order);
  permute(p_.vz, order);
  permute(p_.omega, order);
  permute(p_.fx, order);
  permute(p_.fz, order);
  permute(p_.torque, order);
  permute(p_.radius, order);
  permute(p_.mass, order);
  permute(p_.inv_mass, order);
  permute(p_.inv_inertia, order);
  permute(p_.id, order);
  permute(p_.material, order);
  permute(p_.flags, order);
  ++stats_.reorders;
}

void Engine::rebuild() {
  const std::size_t n = p_.size();
  const int T = threads_in_use();
  const auto tcount = static_cast<std::size_t>(T);
  skin_ = config_.skin_factor * r_min_;
  // Space-filling-curve order every reorder_every rebuilds, and at the first rebuild of a large
  // set (its input order may be anything; small sets keep theirs, which tests index by).
  const bool first_large = stats_.neighbour_rebuilds == 0 && n >= kReorderFirstMin;
  if (config_.reorder_every > 0 &&
      (first_large || rebuilds_since_reorder_ >= config_.reorder_every)) {
    reorder();
    rebuilds_since_reorder_ = 0;
  }
  ++rebuilds_since_reorder_;
  ++stats_.neighbour_rebuilds;

  // Remove particles that left the scene (e.g. fell through an opened wall, the paper's §3 "3D
  // loss"): under gravity, a centre more than 2 r_max below the lowest boundary point can never be
  // caught again; sideways (or without gravity) only far outside the boundaries' bounding box.
  if (!boundaries_.empty()) {
    double bx0 = bvx_[0], bx1 = bvx_[0], bz0 = bvz_[0], bz1 = bvz_[0];
    for (std::size_t k = 0; k < bvx_.size(); ++k) {
      bx0 = std::min(bx0, bvx_[k]);
      bx1 = std::max(bx1, bvx_[k]);
      bz0 = std::min(bz0, bvz_[k]);
      bz1 = std::max(bz1, bvz_[k]);
    }
    const double margin = std::max(bx1 - bx0, bz1 - bz0) + 10.0 * r_max_;
    for (std::size_t i = 0; i < n; ++i)
      if (!(p_.flags[i] & kFlagRemoved) &&
          (p_.z[i] < bz0 - (config_.gravity > 0.0 ? 2.0 * r_max_ : margin) ||
           p_.x[i] < bx0 - margin || p_.x[i] > bx1 + margin)) {
        p_.flags[i] |= kFlagRemoved;
        p_.vx[i] = p_.vz[i] = p_.omega[i] = 0.0;
      }
  }

  // Cell grid: cell size = largest diameter + skin, so every pair within reach sits in
  // neighbouring cells; counting sort of particles into cells.
  std::vector<std::uint32_t> new_start(n + 1, 0), new_j;
  if (n > 0) {
    double xmin = std::numeric_limits<double>::infinity(), zmin = xmin, xmax = -xmin, zmax = -xmin;
    for (std::size_t i = 0; i < n; ++i) {
      if (p_.flags[i] & kFlagRemoved) continue;
      xmin = std::min(xmin, p_.x[i]);
      xmax = std::max(xmax, p_.x[i]);
      zmin = std::min(zmin, p_.z[i]);
      zmax = std::max(zmax, p_.z[i]);
    }
    if (!(xmax >= xmin)) xmin = xmax = zmin = zmax = 0.0;
    double h = 2.0 * r_max_ + skin_;
    auto ncell = [&](double ext) { return static_cast<std::size_t>(ext / h) + 1; };
    while (ncell(xmax - xmin) * ncell(zmax - zmin) > 4 * n + 64) h *= 2.0; // sparse clouds
    const std::size_t nx = ncell(xmax - xmin), nz = ncell(zmax - zmin);
    auto& cell_of = cell_of_;
    auto& cell_start = cell_start_;
    auto& cell_items = cell_items_;
    cell_of.assign(n, 0u);
    cell_start.assign(nx * nz + 1, 0u);
    cell_items.assign(n, 0u);
    for (std::size_t i = 0; i < n; ++i) {
      if (p_.flags[i] & kFlagRemoved) {
        cell_of[i] = ~0u;
        continue;
      }
      const auto cx = std::min(static_cast<std::size_t>((p_.x[i] - xmin) / h), nx - 1);
      const auto cz = std::min(static_cast<std::size_t>((p_.z[i] - zmin) / h), nz - 1);
      cell_of[i] = static_cast<std::uint32_t>(cz * nx + cx);
      ++cell_start[cell_of[i] + 1];
    }
    for (std::size_t c = 0; c < nx * nz; ++c) cell_start[c + 1] += cell_start[c];
    {
      std::vector<std::uint32_t> fill(cell_start.begin(), cell_start.end() - 1);
      for (std::size_t i = 0; i < n; ++i)
        if (cell_of[i] != ~0u) cell_items[fill[cell_of[i]]++] = static_cast<std::uint32_t>(i);
    }
    // Candidate pairs (i < j within cut-off + skin) of the owners i0 ≤ i < i1, appended to `out`
    // in (owner, partner) order; new_start[i] is set relative to out's start.
    auto search = [&](std::size_t i0, std::size_t i1, std::vector<std::uint32_t>& out) {
      out.clear();
      out.reserve((i1 - i0) * 4);
      std::vector<std::uint32_t> local;
      for (std::size_t i = i0; i < i1; ++i) {
        new_start[i] = static_cast<std::uint32_t>(out.size());
        if (cell_of[i] == ~0u) continue;
        const std::size_t cx = cell_of[i] % nx, cz = cell_of[i] / nx;
        local.clear();
        for (std::size_t zz = cz > 0 ? cz - 1 : 0; zz <= std::min(cz + 1, nz - 1); ++zz)
          for (std::size_t xx = cx > 0 ? cx - 1 : 0; xx <= std::min(cx + 1, nx - 1); ++xx) {
            const std::size_t c = zz * nx + xx;
            for (std::uint32_t k = cell_start[c]; k < cell_start[c + 1]; ++k) {
              const std::uint32_t j = cell_items[k];
              if (j <= i) continue;
              const double dx = p_.x[i] - p_.x[j], dz = p_.z[i] - p_.z[j];
              const double cut = p_.radius[i] + p_.radius[j] + skin_;
              if (dx * dx + dz * dz < cut * cut) local.push_back(j);
            }
          }
        std::sort(local.begin(), local.end());
        out.insert(out.end(), local.begin(), local.end());
      }
    };
    if (T <= 1) {
      search(0, n, new_j);
    } else { // contiguous owner chunks, concatenated in order: the same list for any thread count
      std::vector<std::vector<std::uint32_t>> tj(tcount);
#pragma omp parallel num_threads(team_size())
      {
        const auto [t0, ts] = team_member();
        for (std::size_t t = t0; t < tcount; t += ts) search(n * t / tcount, n * (t + 1) / tcount, tj[t]);
      }
      std::size_t total = 0;
      for (const auto& v : tj) total += v.size();
      new_j.resize(total);
      std::size_t base = 0;
      for (std::size_t t = 0; t < tcount; ++t) {
        for (std::size_t i = n * t / tcount; i < n * (t + 1) / tcount; ++i)
          new_start[i] += static_cast<std::uint32_t>(base);
        std::copy(tj[t].begin(), tj[t].end(), new_j.begin() + static_cast<std::ptrdiff_t>(base));
        base += tj[t].size();
      }
    }
    new_start[n] = static_cast<std::uint32_t>(new_j.size());
  }
  // Carry the history over: both lists are sorted by (owner, partner).
  std::vector<ContactHistory> new_hist(new_j.size());
  if (nbr_start_.size() == n + 1) {
#pragma omp parallel for num_threads(team_size()) schedule(static) if (T > 1)
    for (std::size_t i = 0; i < n; ++i) {
      std::uint32_t a = nbr_start_[i];
      const std::uint32_t ae = nbr_start_[i + 1];
      for (std::uint32_t k = new_start[i]; k < new_start[i + 1] && a < ae; ++k) {
        while (a < ae && nbr_j_[a] < new_j[k]) ++a;
        if (a < ae && nbr_j_[a] == new_j[k]) new_hist[k] = nbr_hist_[a];
      }
    }
  }
  nbr_start_.swap(new_start);
  nbr_j_.swap(new_j);
  nbr_hist_.swap(new_hist);

  // Boundary candidates: every (particle, active feature) pair within reach.
  std::vector<std::uint32_t> ni, nf;
  for (std::size_t i = 0; i < n; ++i) {
    if (p_.flags[i] & kFlagRemoved) continue;
    const double reach = p_.radius[i] + skin_;
    for (std::size_t f = 0; f < features_.size(); ++f) {
      const Feature& F = features_[f];
      if (!boundaries_[F.boundary].active) continue;
      double d2;
      const double px = p_.x[i], pz = p_.z[i];
      if (F.v0 == F.v1) {
        const double dx = px - bvx_[F.v0], dz = pz - bvz_[F.v0];
        d2 = dx * dx + dz * dz;
      } else {
        const double ax = bvx_[F.v0], az = bvz_[F.v0];
        const double ex = bvx_[F.v1] - ax, ez = bvz_[F.v1] - az;
        const double len2 = ex * ex + ez * ez;
        double t = len2 > 0.0 ? ((px - ax) * ex + (pz - az) * ez) / len2 : 0.0;
        t = std::clamp(t, 0.0, 1.0);
        const double dx = px - ax - t * ex, dz = pz - az - t * ez;
        d2 = dx * dx + dz * dz;
      }
      if (d2 < reach * reach) {
        ni.push_back(static_cast<std::uint32_t>(i));
        nf.push_back(static_cast<std::uint32_t>(f));
      }
    }
  }
  std::vector<ContactHistory> nh(ni.size());
  {
    std::size_t a = 0;
    for (std::size_t k = 0; k < ni.size(); ++k) {
      while (a < bnd_i_.size() && (bnd_i_[a] < ni[k] || (bnd_i_[a] == ni[k] && bnd_f_[a] < nf[k])))
        ++a;
      if (a < bnd_i_.size() && bnd_i_[a] == ni[k] && bnd_f_[a] == nf[k]) nh[k] = bnd_hist_[a];
    }
  }
  bnd_i_.swap(ni);
  bnd_f_.swap(nf);
  bnd_hist_.swap(nh);

  x_ref_ = p_.x;
  z_ref_ = p_.z;
  bvx_ref_ = bvx_;
  bvz_ref_ = bvz_;
  stats_.pair_entries = nbr_j_.size();
  stats_.boundary_entries = bnd_i_.size();
  need_rebuild_ = false;
}

// ---- forces -------------------------------------------------------------------------------------

// Particle–particle forces of the owners i0 ≤ i < i1 (pairs i < j), accumulated into fx, fz, tq
// (the particle arrays, or one thread's buffers). energies[0..4]: friction, damping, rebound,
// normal spring, shear spring of these pairs. fail_pair: the first pair above max_overlap
// (i, j), left unchanged when none.
template <class Law>
void Engine::pair_range(const Law& law, std::size_t i0, std::size_t i1, double* __restrict fx,
                        double* __restrict fz, double* __restrict tq, double* energies,
                        std::uint32_t* fail_pair) {
  const double dt = dt_;
  const double* __restrict x = p_.x.data();
  const double* __restrict z = p_.z.data();
  const double* __restrict vx = p_.vx.data();
  const double* __restrict vz = p_.vz.data();
  const double* __restrict om = p_.omega.data();
  const double* __restrict rad = p_.radius.data();
  const double* __restrict mass = p_.mass.data();
  const auto& mats = config_.materials;
  const bool one_material = mats.size() == 1;
  double e_fric = 0.0, e_damp = 0.0, e_reb = 0.0, e_n = 0.0, e_s = 0.0;
  const double max_ov = config_.max_overlap;
  bool failed = fail_pair[0] != ~0u;
  for (std::size_t i = i0; i < i1; ++i) {
    const std::uint32_t kb = nbr_start_[i], ke = nbr_start_[i + 1];
    if (kb == ke) continue;
    const double xi = x[i], zi = z[i], ri = rad[i];
    double fxi = 0.0, fzi = 0.0, ti = 0.0;
    for (std::uint32_t k = kb; k < ke; ++k) {
      const std::uint32_t j = nbr_j_[k];
      ContactHistory& h = nbr_hist_[k];
      const double dx = xi - x[j], dz = zi - z[j];
      const double rsum = ri + rad[j];
      const double d2 = dx * dx + dz * dz;
      const double dvx = vx[i] - vx[j], dvz = vz[i] - vz[j];
      if (d2 >= rsum * rsum && h.flags == 0) continue; // not touching, no history
      const double dist = std::sqrt(d2);
      const double delta = rsum - dist; // eq. 2.3
      const double inv = dist > 0.0 ? 1.0 / dist : 0.0;
      const double nx = dx * inv, nz = dz * inv; // from j to i (eq. 2.4: cos α, sin α)
      const double tx = -nz, tz = nx;
      const double li = ri - 0.5 * delta, lj = rad[j] - 0.5 * delta; // l_i + l_j = |x_i − x_j|
      ContactInput in;
      in.delta = delta;
      in.vn = -(dvx * nx + dvz * nz);                          // eq. 2.5, approach positive
      in.vs = dvx * tx + dvz * tz - (li * om[i] + lj * om[j]); // eq. 2.5, slip
      in.m_eff = mass[i] * mass[j] / (mass[i] + mass[j]);
      in.r_eff = ri * rad[j] / rsum;
      if (one_material) {
        in.mu_s = mats[0].mu_s;
        in.mu_d = mats[0].mu_d;
      } else { // the weaker of the two materials
        const auto& a = mats[p_.material[i]];
        const auto& b = mats[p_.material[j]];
        in.mu_s = std::min(a.mu_s, b.mu_s);
        in.mu_d = std::min(a.mu_d, b.mu_d);
      }
      in.dt = dt;
      const ContactResult r = law.evaluate(in, h);
      e_fric += r.e_friction;
      if (!r.touching) continue;
      e_damp += r.e_damping;
      e_reb += r.e_rebound;
      e_n += r.e_normal;
      e_s += r.e_shear;
      if (delta > max_ov * std::min(ri, rad[j]) && !failed) {
        failed = true;
        fail_pair[0] = static_cast<std::uint32_t>(i);
        fail_pair[1] = j;
      }
      const double fnt = r.fn + r.impulse;
      const double Fx = fnt * nx + r.ft * tx, Fz = fnt * nz + r.ft * tz; // eq. 2.15
      fxi += Fx;
      fzi += Fz;
      ti -= li * r.ft;
      fx[j] -= Fx;
      fz[j] -= Fz;
      tq[j] -= lj * r.ft;
    }
    fx[i] += fxi;
    fz[i] += fzi;
    tq[i] += ti;
  }
  energies[0] += e_fric;
  energies[1] += e_damp;
  energies[2] += e_reb;
  energies[3] += e_n;
  energies[4] += e_s;
}

int Engine::team_size() const {
  const int T = threads_in_use();
  return team_ > 0 ? std::min(team_, T) : T;
}

std::pair<std::size_t, std::size_t> Engine::team_member() {
#ifdef _OPENMP
  return {static_cast<std::size_t>(omp_get_thread_num()),
          static_cast<std::size_t>(omp_get_num_threads())};
#else
  return {0, 1};
#endif
}

int Engine::threads_in_use() const {
  if (p_.size() < config_.parallel_min_particles) return 1;
  int t = config_.threads;
#ifdef _OPENMP
  if (t <= 0) t = omp_get_max_threads();
#else
  t = 1;
#endif
  return std::max(t, 1);
}

template <class Law> void Engine::pair_forces(const Law& law) {
  const std::size_t n = p_.size();
  const int T = threads_in_use();
  double en[5] = {0, 0, 0, 0, 0};
  std::uint32_t fail[2] = {~0u, ~0u};
  if (T <= 1) {
    pair_range(law, 0, n, p_.fx.data(), p_.fz.data(), p_.torque.data(), en, fail);
  } else {
    // Deterministic for a fixed thread count: thread t takes the owners in split_[t]…split_[t+1]
    // (equal shares of pair entries) and accumulates into its own buffers; the buffers are then
    // summed per particle in thread order.
    const auto tcount = static_cast<std::size_t>(T);
    split_.assign(tcount + 1, n);
    split_[0] = 0;
    const std::uint32_t total = nbr_start_[n];
    for (std::size_t t = 1; t < tcount; ++t) {
      const auto target = static_cast<std::uint32_t>(
          static_cast<double>(total) * static_cast<double>(t) / static_cast<double>(tcount));
      split_[t] = static_cast<std::size_t>(
          std::lower_bound(nbr_start_.begin(), nbr_start_.begin() + static_cast<std::ptrdiff_t>(n),
                           target) -
          nbr_start_.begin());
      split_[t] = std::max(split_[t], split_[t - 1]);
    }
    // Part 0 accumulates straight into the (zeroed) particle force arrays, parts 1 … T−1 into
    // their own buffers, which are then added per particle in part order: f = f₀ + (f₁ + …).
    if (tbuf_.size() < 3 * n * (tcount - 1)) tbuf_.resize(3 * n * (tcount - 1));
    std::vector<double> ten(5 * tcount, 0.0);
    std::vector<std::uint32_t> tfail(2 * tcount, ~0u);
    double* buf = tbuf_.data();
    double* fxo = p_.fx.data();
    double* fzo = p_.fz.data();
    double* tqo = p_.torque.data();
#pragma omp parallel num_threads(team_size())
    {
      // Part t of the T parts always accumulates into buffer t, whichever thread runs it: the
      // result depends on T only, not on how many threads the adaptive team has right now.
      const auto [t0, ts] = team_member();
      for (std::size_t t = t0; t < tcount; t += ts) {
        double* bx = t == 0 ? fxo : buf + 3 * n * (t - 1);
        double* bz = t == 0 ? fzo : bx + n;
        double* bt = t == 0 ? tqo : bz + n;
        if (t > 0) std::fill(bx, bx + 3 * n, 0.0);
        pair_range(law, split_[t], split_[t + 1], bx, bz, bt, &ten[5 * t], &tfail[2 * t]);
      }
#pragma omp barrier
#pragma omp for schedule(static)
      for (std::size_t i = 0; i < n; ++i) {
        double sx = 0.0, sz = 0.0, st = 0.0;
        for (std::size_t u = 0; u + 1 < tcount; ++u) {
          sx += buf[3 * n * u + i];
          sz += buf[3 * n * u + n + i];
          st += buf[3 * n * u + 2 * n + i];
        }
        fxo[i] += sx;
        fzo[i] += sz;
        tqo[i] += st;
      }
    }
    for (std::size_t t = 0; t < tcount; ++t) {
      for (int q = 0; q < 5; ++q) en[q] += ten[5 * t + static_cast<std::size_t>(q)];
      if (fail[0] == ~0u && tfail[2 * t] != ~0u) {
        fail[0] = tfail[2 * t];
        fail[1] = tfail[2 * t + 1];
      }
    }
  }
  if (fail[0] != ~0u && failure_.empty()) {
    const std::uint32_t i = fail[0], j = fail[1];
    const double delta =
        p_.radius[i] + p_.radius[j] - std::hypot(p_.x[i] - p_.x[j], p_.z[i] - p_.z[j]);
    failure_ = fmt::format("overlap {:.3g} m exceeds max_overlap·r between particles {} and {}",
                           delta, p_.id[i], p_.id[j]);
  }
  e_friction_ += en[0];
  e_damping_ += en[1];
  e_rebound_ += en[2];
  e_normal_ = en[3];
  e_shear_ = en[4];
}

template <class Law> void Engine::boundary_forces(const Law& law) {
  const double dt = dt_;
  for (auto& b : boundaries_) b.reaction_x = b.reaction_z = 0.0;
  for (auto& s : structures_) s.soil_fx = s.soil_fz = s.soil_moment = 0.0;
  double e_fric = 0.0, e_damp = 0.0, e_reb = 0.0, e_n = 0.0, e_s = 0.0;
  const std::size_t m = bnd_i_.size();
  for (std::size_t k = 0; k < m; ++k) {
    const std::uint32_t i = bnd_i_[k];
    const Feature& F = features_[bnd_f_[k]];
    Boundary& B = boundaries_[F.boundary];
    ContactHistory& h = bnd_hist_[k];
    if (!B.active) {
      h = ContactHistory{};
      continue;
    }
    const double px = p_.x[i], pz = p_.z[i], ri = p_.radius[i];
    // Closest point q on the feature and the normal from q towards the centre.
    double qx, qz, nx, nz, dist;
    bool valid = true;
    if (F.v0 == F.v1) { // vertex: only in its own Voronoi region (no adjacent edge contact)
      qx = bvx_[F.v0];
      qz = bvz_[F.v0];
      for (std::int32_t adj : {F.adj0, F.adj1}) {
        if (adj < 0) continue;
        const Feature& S = features_[static_cast<std::size_t>(adj)];
        const double ax = bvx_[S.v0], az = bvz_[S.v0];
        const double ex = bvx_[S.v1] - ax, ez = bvz_[S.v1] - az;
        const double t = ((px - ax) * ex + (pz - az) * ez) / (ex * ex + ez * ez);
        if (t > 0.0 && t < 1.0) valid = false;
      }
      const double dx = px - qx, dz = pz - qz;
      dist = std::sqrt(dx * dx + dz * dz);
      nx = dist > 0.0 ? dx / dist : 0.0;
      nz = dist > 0.0 ? dz / dist : 1.0;
    } else {
      const double ax = bvx_[F.v0], az = bvz_[F.v0];
      const double ex = bvx_[F.v1] - ax, ez = bvz_[F.v1] - az;
      const double len2 = ex * ex + ez * ez;
      const double t = ((px - ax) * ex + (pz - az) * ez) / len2;
      if (!(t > 0.0 && t < 1.0)) valid = false;
      qx = ax + t * ex;
      qz = az + t * ez;
      if (B.closed) { // structure edge: one-sided, outward normal of a counter-clockwise outline
        const double len = std::sqrt(len2);
        nx = ez / len;
        nz = -ex / len;
        dist = (px - ax) * nx + (pz - az) * nz;
        if (dist < -ri) valid = false;
      } else {
        const double dx = px - qx, dz = pz - qz;
        dist = std::sqrt(dx * dx + dz * dz);
        nx = dist > 0.0 ? dx / dist : 0.0;
        nz = dist > 0.0 ? dz / dist : 1.0;
      }
    }
    double delta = ri - dist;
    if (!valid) delta = -1.0e300; // not this feature's contact: ends any history
    const double tx = -nz, tz = nx;
    const double li = ri - std::max(delta, 0.0);
    // Velocity of the boundary at q (rigid structure: v_P + ω × (q − P)).
    double bvx = 0.0, bvz = 0.0;
    StructureState* st = nullptr;
    if (B.structure >= 0) {
      st = &structures_[static_cast<std::size_t>(B.structure)];
      const double rx = qx - (st->px0 + st->ux), rz = qz - (st->pz0 + st->uz);
      bvx = st->vx - st->omega * rz;
      bvz = st->vz + st->omega * rx;
    }
    const double dvx = p_.vx[i] - bvx, dvz = p_.vz[i] - bvz;
    ContactInput in;
    in.delta = delta;
    in.vn = -(dvx * nx + dvz * nz);
    in.vs = dvx * tx + dvz * tz - li * p_.omega[i];
    in.m_eff = p_.mass[i];
    in.r_eff = ri;
    if (B.own_friction) {
      in.mu_s = B.mu_s;
      in.mu_d = B.mu_d;
    } else {
      in.mu_s = config_.materials[p_.material[i]].mu_s;
      in.mu_d = config_.materials[p_.material[i]].mu_d;
    }
    in.dt = dt;
    if (!valid && h.flags == 0) continue;
    const ContactResult r = law.evaluate(in, h);
    e_fric += r.e_friction;
    if (!r.touching) continue;
    e_damp += r.e_damping;
    e_reb += r.e_rebound;
    e_n += r.e_normal;
    e_s += r.e_shear;
    if (delta > config_.max_overlap * ri && failure_.empty())
      failure_ = fmt::format("overlap {:.3g} m exceeds max_overlap·r between particle {} and "
                             "boundary '{}'",
                             delta, p_.id[i], B.name);
    const double fnt = r.fn + r.impulse;
    const double Fx = fnt * nx + r.ft * tx, Fz = fnt * nz + r.ft * tz;
    p_.fx[i] += Fx;
    p_.fz[i] += Fz;
    p_.torque[i] -= li * r.ft;
    B.reaction_x -= Fx;
    B.reaction_z -= Fz;
    if (st) {
      st->soil_fx -= Fx;
      st->soil_fz -= Fz;
      const double rx = qx - (st->px0 + st->ux), rz = qz - (st->pz0 + st->uz);
      st->soil_moment += rx * (-Fz) - rz * (-Fx); // (q − P) × (−F)
    }
  }
  e_friction_ += e_fric;
  e_damping_ += e_damp;
  e_rebound_ += e_reb;
  e_normal_ += e_n;
  e_shear_ += e_s;
}

void Engine::compute_forces() {
  const std::size_t n = p_.size();
  std::fill(p_.fx.begin(), p_.fx.end(), 0.0);
  std::fill(p_.fz.begin(), p_.fz.end(), 0.0);
  std::fill(p_.torque.begin(), p_.torque.end(), 0.0);
  switch (config_.law) {
  case scene::ContactLaw::CundallRebound: {
    CundallRebound law;
    law.p = {config_.kn,      config_.ks,
             config_.rebound, config_.rebound_speed,
             config_.tension, config_.tensile_strength};
    pair_forces(law);
    boundary_forces(law);
    break;
  }
  case scene::ContactLaw::CundallDashpot: {
    CundallDashpot law;
    law.p = {config_.kn, config_.ks, config_.eta_n, config_.eta_s};
    pair_forces(law);
    boundary_forces(law);
    break;
  }
  case scene::ContactLaw::LinearRestitution: {
    LinearRestitution law;
    law.p = {config_.kn, config_.ks, LinearRestitution::damping_ratio(config_.restitution)};
    pair_forces(law);
    boundary_forces(law);
    break;
  }
  case scene::ContactLaw::HertzMindlin: {
    HertzMindlin law;
    const double E = config_.young, nu = config_.poisson;
    law.p.e_star = E / (2.0 * (1.0 - nu * nu));         // equal materials
    law.p.g_star = E / (4.0 * (2.0 - nu) * (1.0 + nu)); // G/(2(2−ν)) with G = E/(2(1+ν))
    pair_forces(law);
    boundary_forces(law);
    break;
  }
  }
  (void)n;
}

// ---- integration --------------------------------------------------------------------------------

// Integrates particles i0 ≤ i < i1. sums[0]: external work, sums[1]: damping dissipation;
// *bad: the first non-finite particle index (unchanged when none).
void Engine::integrate_range(std::size_t i0, std::size_t i1, double ax_body, double az_body,
                             double* sums, std::size_t* bad) {
  const double dt = dt_;
  const double g = config_.gravity;
  const double C = config_.damping_c, D = config_.damping_d;
  // Local restrict pointers: the loop touches only these arrays (lets the compiler keep them in
  // registers instead of reloading them from the vectors after every store).
  double* __restrict x = p_.x.data();
  double* __restrict z = p_.z.data();
  double* __restrict phi = p_.phi.data();
  double* __restrict vx = p_.vx.data();
  double* __restrict vz = p_.vz.data();
  double* __restrict om = p_.omega.data();
  const double* __restrict fxa = p_.fx.data();
  const double* __restrict fza = p_.fz.data();
  const double* __restrict tqa = p_.torque.data();
  const double* __restrict mass = p_.mass.data();
  const double* __restrict inv_mass = p_.inv_mass.data();
  const double* __restrict inv_inertia = p_.inv_inertia.data();
  const std::uint32_t* __restrict flags = p_.flags.data();
  double w_ext = 0.0, e_damp = 0.0;
  std::size_t first_bad = *bad;
  for (std::size_t i = i0; i < i1; ++i) {
    if (flags[i] & kFlagRemoved) continue;
    const double m = mass[i], im = inv_mass[i], ii = inv_inertia[i];
    // eq. 2.1: m ü + C u̇ + F = 0 with C per unit mass; eq. 2.2 likewise with D per inertia.
    const double vx0 = vx[i], vz0 = vz[i], om0 = om[i];
    const double fx = fxa[i] + m * ax_body - C * m * vx0;
    const double fz = fza[i] + m * (az_body - g) - C * m * vz0;
    const double tq = tqa[i] - D * om0 / ii;
    const double vx1 = vx0 + fx * im * dt; // eq. 2.16
    const double vz1 = vz0 + fz * im * dt;
    const double om1 = om0 + tq * ii * dt; // eq. 2.17
    vx[i] = vx1;
    vz[i] = vz1;
    om[i] = om1;
    const double x1 = x[i] + vx1 * dt; // eq. 2.18
    const double z1 = z[i] + vz1 * dt;
    x[i] = x1;
    z[i] = z1;
    phi[i] += om1 * dt;
    w_ext += m * (ax_body * vx1 + az_body * vz1) * dt;
    if (C > 0.0) e_damp += C * m * (0.5 * (vx0 + vx1) * vx1 + 0.5 * (vz0 + vz1) * vz1) * dt;
    if (D > 0.0) e_damp += D / ii * 0.5 * (om0 + om1) * om1 * dt;
    if (!std::isfinite(x1 + z1 + om1) && first_bad == ~std::size_t{0}) first_bad = i;
  }
  *bad = first_bad;
  sums[0] += w_ext;
  sums[1] += e_damp;
}

void Engine::integrate() {
  const std::size_t n = p_.size();
  double ax_body = 0.0, az_body = 0.0;
  if (config_.shaking) {
    const double a = config_.shaking_acceleration(time_); // body force m·A·sin(2πft) (paper §6)
    (config_.shaking_direction == 'z' ? az_body : ax_body) = a;
  }
  const std::size_t none = ~std::size_t{0};
  double sums[2] = {0.0, 0.0};
  std::size_t bad = none;
  const int T = threads_in_use();
  if (T <= 1) {
    integrate_range(0, n, ax_body, az_body, sums, &bad);
  } else {
    // Static contiguous chunks; partial sums combined in thread order (deterministic per count).
    const auto tcount = static_cast<std::size_t>(T);
    std::vector<double> ts(2 * tcount, 0.0);
    std::vector<std::size_t> tb(tcount, none);
#pragma omp parallel num_threads(team_size())
    {
      const auto [t0, tstride] = team_member();
      for (std::size_t t = t0; t < tcount; t += tstride)
        integrate_range(n * t / tcount, n * (t + 1) / tcount, ax_body, az_body, &ts[2 * t], &tb[t]);
    }
    for (std::size_t t = 0; t < tcount; ++t) {
      sums[0] += ts[2 * t];
      sums[1] += ts[2 * t + 1];
      if (bad == none) bad = tb[t];
    }
  }
  e_external_ += sums[0];
  e_damping_ += sums[1];
  if (bad != none && failure_.empty())
    failure_ = fmt::format("non-finite position or velocity of particle {}", p_.id[bad]);
}

void Engine::update_structures() {
  if (structures_.empty()) return;
  ++stats_.structure_updates;
  const double dt = dt_;
  const double g = config_.gravity;
  const double tn = time_ + dt;
  for (auto& st : structures_) {
    const auto& sp = st.spec;
    const double c = std::cos(st.rot), s = std::sin(st.rot);
    const double px = st.px0 + st.ux, pz = st.pz0 + st.uz;
    // External loads: force at the load point (rotating with the body) and a moment.
    const double lx0 = sp.load_point.x - st.px0, lz0 = sp.load_point.z - st.pz0;
    const double lrx = c * lx0 - s * lz0, lrz = s * lx0 + c * lz0;
    st.applied_fx = sp.force_x(time_);
    st.applied_fz = sp.force_z(time_);
    st.applied_moment = sp.moment(time_) + lrx * st.applied_fz - lrz * st.applied_fx;
    // Dead weight at the centroid.
    const double crx = c * st.cx_local - s * st.cz_local; // centroid lever arm (x)
    const double W = sp.dead_weight ? st.mass * g : 0.0;
    const double Fx = st.soil_fx + st.applied_fx;
    const double Fz = st.soil_fz + st.applied_fz - W;
    const double M = st.soil_moment + st.applied_moment + crx * (-W); // paper eqs. 5.2–5.7
    const double vx0 = st.vx, vz0 = st.vz, om0 = st.omega;
    auto advance = [&](scene::DofMode mode, const scene::TimeFunction& motion, double force,
                       double inv_m, double& u, double& v) {
      switch (mode) {
      case scene::DofMode::Fixed:
        v = 0.0;
        break;
      case scene::DofMode::Free:
        v += force * inv_m * dt; // symplectic Euler, like the particles
        u += v * dt;
        break;
      case scene::DofMode::Prescribed: {
        const double un = motion(tn);
        v = (un - u) / dt;
        u = un;
        break;
      }
      }
    };
    advance(sp.dof_x, sp.motion_x, Fx, 1.0 / st.mass, st.ux, st.vx);
    advance(sp.dof_z, sp.motion_z, Fz, 1.0 / st.mass, st.uz, st.vz);
    // Rotation about the pivot: I_P θ̈ = M_P (paper eq. 5.7). With free translations the
    // coupling through a centroid off the pivot is neglected (exact when pivot = centroid).
    advance(sp.dof_rotation, sp.motion_rotation, M, 1.0 / st.inertia, st.rot, st.omega);
    // Work of the external loads on the structure (free DOFs) and of imposed motions.
    double w = 0.0;
    if (sp.dof_x == scene::DofMode::Free) w += st.applied_fx * st.vx * dt;
    if (sp.dof_z == scene::DofMode::Free) w += st.applied_fz * st.vz * dt;
    if (sp.dof_rotation == scene::DofMode::Free) w += st.applied_moment * st.omega * dt;
    // Imposed motion: the driver does the work the soil receives, −(soil force)·v.
    if (sp.dof_x == scene::DofMode::Prescribed) w -= st.soil_fx * st.vx * dt;
    if (sp.dof_z == scene::DofMode::Prescribed) w -= st.soil_fz * st.vz * dt;
    if (sp.dof_rotation == scene::DofMode::Prescribed) w -= st.soil_moment * st.omega * dt;
    e_external_ += w;
    (void)vx0;
    (void)vz0;
    (void)om0;
    (void)px;
    (void)pz;
  }
  update_boundary_vertices();
}

void Engine::step() {
  if (!(dt_ > 0.0)) set_dt(auto_dt());
  if (!pe_ref_set_) {
    pe_ref_set_ = true;
    pe_ref_ = 0.0;
    const double g = config_.gravity;
    for (std::size_t i = 0; i < p_.size(); ++i) pe_ref_ += p_.mass[i] * g * p_.z[i];
    for (const auto& st : structures_)
      if (st.spec.dead_weight) pe_ref_ += st.mass * g * (st.pz0 + st.uz + st.cz_local);
  }
  const auto t0 = std::chrono::steady_clock::now();
  check_rebuild();
  const auto t1 = std::chrono::steady_clock::now();
  compute_forces();
  const auto t2 = std::chrono::steady_clock::now();
  stats_.rebuild_seconds += std::chrono::duration<double>(t1 - t0).count();
  stats_.force_seconds += std::chrono::duration<double>(t2 - t1).count();
  integrate();
  update_structures();
  time_ += dt_;
  ++stats_.steps;
  tune_team();
}

void Engine::tune_team() {
  const int T = threads_in_use();
  if (T <= 1) return;
  const bool one = team_size() == 1;
  ++(one ? stats_.team_one_steps : stats_.team_full_steps);
  auto& tu = tuner_;
  if (tu.fixed || !config_.adaptive_threads) return;
  const auto now = std::chrono::steady_clock::now();
  if (!tu.started) { // start with one thread and probe the full team at once: a stalled full
    tu.started = true; // team is what costs, so it is only ever tried for short probes
    tu.t0 = now;
    tu.steps = 0;
    tu.current = 1;
    team_ = 1;
    tu.until_probe = 1;
    tu.probe_every = 1;
    return;
  }
  ++tu.steps;
  const double elapsed = std::chrono::duration<double>(now - tu.t0).count();
  // A probe behind the current choice's pace (after at least a quarter window's worth of time)
  // has lost: stop it now. A stalled team can be 10–50× slower; a whole window of it would cost
  // more than the adaptation gains.
  const bool lost =
      tu.probing && elapsed > tu.current_per_step *
                                  static_cast<double>(std::max(tu.steps, tu.window / 4)) / 0.95;
  if (tu.steps < tu.window && !lost) return;
  const double per = elapsed / static_cast<double>(tu.steps);
  // Windows of ≈ 0.1 s of the current choice: long enough to average over rebuilds and
  // scheduler slices, short enough to follow a core that becomes busy or free.
  if (!tu.probing && elapsed < 0.05 && tu.window < (1L << 16)) tu.window *= 2;
  if (!tu.probing && elapsed > 0.2 && tu.window > 1) tu.window /= 2;
  if (tu.probing) {
    tu.probing = false;
    if (!lost && per < 0.95 * tu.current_per_step) { // the other choice is faster: keep it
      tu.current = team_;
      tu.current_per_step = per;
      tu.probe_every = 1;
      ++stats_.team_switches;
    } else { // back, and probe less often while the current choice keeps winning
      team_ = tu.current;
      tu.probe_every = std::min(2 * tu.probe_every, 64);
    }
    tu.until_probe = tu.probe_every;
  } else {
    tu.current_per_step = per;
    if (--tu.until_probe <= 0) {
      tu.probing = true;
      team_ = tu.current == 1 ? 0 : 1;
    }
  }
  tu.t0 = now;
  tu.steps = 0;
}

void Engine::run_steps(long long n) {
  for (long long k = 0; k < n && failure_.empty(); ++k) step();
}

// ---- events -------------------------------------------------------------------------------------

void Engine::open_wall(const std::string& name) {
  const int b = boundary_index(name);
  if (b < 0) throw std::runtime_error("open_wall: no wall named '" + name + "'");
  boundaries_[static_cast<std::size_t>(b)].active = false;
  need_rebuild_ = true;
}

std::size_t Engine::set_friction(const scene::Polygon& region, double mu_s, double mu_d) {
  const std::uint16_t mat = add_material({mu_s, mu_d});
  std::size_t count = 0;
  for (std::size_t i = 0; i < p_.size(); ++i)
    if (scene::contains(region, {p_.x[i], p_.z[i]})) {
      p_.material[i] = mat;
      ++count;
    }
  return count;
}

// ---- observation --------------------------------------------------------------------------------

EnergyBudget Engine::energy() const {
  EnergyBudget e;
  const double g = config_.gravity;
  double pe = 0.0;
  for (std::size_t i = 0; i < p_.size(); ++i) {
    if (p_.flags[i] & kFlagRemoved) continue;
    e.kinetic += 0.5 * p_.mass[i] * (p_.vx[i] * p_.vx[i] + p_.vz[i] * p_.vz[i]);
    e.rotational += 0.5 / p_.inv_inertia[i] * p_.omega[i] * p_.omega[i];
    pe += p_.mass[i] * g * p_.z[i];
  }
  for (const auto& st : structures_) {
    e.kinetic += 0.5 * st.mass * (st.vx * st.vx + st.vz * st.vz);
    e.rotational += 0.5 * st.inertia * st.omega * st.omega;
    if (st.spec.dead_weight) {
      const double c = std::cos(st.rot), s = std::sin(st.rot);
      pe += st.mass * g * (st.pz0 + st.uz + s * st.cx_local + c * st.cz_local);
    }
  }
  e.potential = pe - (pe_ref_set_ ? pe_ref_ : pe);
  e.gravity_work = -e.potential;
  e.spring_normal = e_normal_;
  e.spring_shear = e_shear_;
  e.friction = e_friction_;
  e.damping = e_damping_;
  e.rebound = e_rebound_;
  e.external_work = e_external_;
  return e;
}

void Engine::contacts(std::vector<ContactView>& out) const {
  out.clear();
  for (std::size_t i = 0; i + 1 < nbr_start_.size(); ++i)
    for (std::uint32_t k = nbr_start_[i]; k < nbr_start_[i + 1]; ++k) {
      const auto& h = nbr_hist_[k];
      if (!(h.flags & kHistActive)) continue;
      const std::uint32_t j = nbr_j_[k];
      const double dx = p_.x[i] - p_.x[j], dz = p_.z[i] - p_.z[j];
      const double d = std::sqrt(dx * dx + dz * dz);
      const double delta = p_.radius[i] + p_.radius[j] - d;
      const double li = p_.radius[i] - 0.5 * delta;
      ContactView v;
      v.i = static_cast<std::uint32_t>(i);
      v.j = j;
      v.cx = p_.x[i] - dx / d * li;
      v.cz = p_.z[i] - dz / d * li;
      v.fn = h.fn;
      v.fs = h.ft;
      v.tensile = h.fn < 0.0f;
      out.push_back(v);
    }
  for (std::size_t k = 0; k < bnd_i_.size(); ++k) {
    const auto& h = bnd_hist_[k];
    if (!(h.flags & kHistActive)) continue;
    const auto& F = features_[bnd_f_[k]];
    const std::uint32_t i = bnd_i_[k];
    ContactView v;
    v.i = i;
    v.j = -1 - static_cast<std::int64_t>(F.boundary);
    // Contact point: the closest point of the feature.
    if (F.v0 == F.v1) {
      v.cx = bvx_[F.v0];
      v.cz = bvz_[F.v0];
    } else {
      const double ax = bvx_[F.v0], az = bvz_[F.v0];
      const double ex = bvx_[F.v1] - ax, ez = bvz_[F.v1] - az;
      const double t =
          std::clamp(((p_.x[i] - ax) * ex + (p_.z[i] - az) * ez) / (ex * ex + ez * ez), 0.0, 1.0);
      v.cx = ax + t * ex;
      v.cz = az + t * ez;
    }
    v.fn = h.fn;
    v.fs = h.ft;
    v.tensile = h.fn < 0.0f;
    out.push_back(v);
  }
}

void Engine::boundary_vertices(int b, std::vector<scene::Vec2>& out) const {
  out.clear();
  const auto& B = boundaries_[static_cast<std::size_t>(b)];
  for (std::uint32_t k = B.first_vertex; k < B.first_vertex + B.vertex_count; ++k)
    out.push_back({bvx_[k], bvz_[k]});
}

void Engine::boundary_views(std::vector<BoundaryView>& out) const {
  out.clear();
  for (const auto& B : boundaries_) {
    BoundaryView v;
    v.name = B.name;
    v.closed = B.closed;
    v.open = !B.active;
    for (std::uint32_t k = B.first_vertex; k < B.first_vertex + B.vertex_count; ++k) {
      v.x.push_back(bvx_[k]);
      v.z.push_back(bvz_[k]);
    }
    out.push_back(std::move(v));
  }
}

// ---- checkpoint / resume -----------------------------------------------------------------------

namespace {
constexpr std::uint32_t kStateMagic = 0x44454d53; // "DEMS"
constexpr std::uint32_t kStateVersion = 1;
constexpr std::uint32_t kHistoryMagic = 0x44454d48; // "DEMH"

void write_hist(detail::ByteWriter& w, const std::vector<ContactHistory>& h) {
  w.value(static_cast<std::uint64_t>(h.size()));
  for (const auto& c : h) { // field by field: no padding bytes in the file
    w.value(c.ft);
    w.value(c.fn);
    w.value(c.flags);
  }
}
void read_hist(detail::ByteReader& r, std::vector<ContactHistory>& h) {
  const auto n = r.value<std::uint64_t>();
  h.clear();
  for (std::uint64_t k = 0; k < n; ++k) {
    ContactHistory c;
    r.value(c.ft);
    r.value(c.fn);
    r.value(c.flags);
    h.push_back(c);
  }
}
} // namespace

std::vector<std::byte> Engine::save_state() const {
  detail::ByteWriter w;
  w.value(kStateMagic);
  w.value(kStateVersion);
  w.value(static_cast<std::uint64_t>(p_.size()));
  w.value(static_cast<std::uint64_t>(boundaries_.size()));
  w.value(static_cast<std::uint64_t>(structures_.size()));
  w.value(static_cast<std::uint64_t>(features_.size()));
  w.value(dt_);
  w.value(time_);
  w.value(stats_.steps);
  w.value(stats_.neighbour_rebuilds);
  w.value(stats_.reorders);
  w.value(stats_.structure_updates);
  w.value(static_cast<std::uint64_t>(stats_.pair_entries));
  w.value(static_cast<std::uint64_t>(stats_.boundary_entries));
  w.value(static_cast<std::uint64_t>(config_.materials.size()));
  for (const auto& m : config_.materials) {
    w.value(m.mu_s);
    w.value(m.mu_d);
  }
  for (const auto& b : boundaries_) {
    w.value(static_cast<std::uint8_t>(b.active ? 1 : 0));
    w.value(b.reaction_x);
    w.value(b.reaction_z);
  }
  w.vec(bvx_);
  w.vec(bvz_);
  w.vec(bvx_ref_);
  w.vec(bvz_ref_);
  for (const auto& st : structures_)
    for (double v : {st.ux, st.uz, st.rot, st.vx, st.vz, st.omega, st.soil_fx, st.soil_fz,
                     st.soil_moment, st.applied_fx, st.applied_fz, st.applied_moment})
      w.value(v);
  w.vec(nbr_start_);
  w.vec(nbr_j_);
  write_hist(w, nbr_hist_);
  w.vec(bnd_i_);
  w.vec(bnd_f_);
  write_hist(w, bnd_hist_);
  w.vec(x_ref_);
  w.vec(z_ref_);
  for (double v : {skin_, r_min_, r_max_, m_min_}) w.value(v);
  w.value(static_cast<std::uint8_t>(need_rebuild_ ? 1 : 0));
  w.value(rebuilds_since_reorder_);
  w.value(next_id_);
  for (double v : {e_friction_, e_damping_, e_rebound_, e_external_, e_normal_, e_shear_, pe_ref_})
    w.value(v);
  w.value(static_cast<std::uint8_t>(pe_ref_set_ ? 1 : 0));
  return std::move(w.buffer());
}

void Engine::restore_state(Particles particles, std::span<const std::byte> state) {
  detail::ByteReader r(state);
  if (r.value<std::uint32_t>() != kStateMagic) detail::ByteReader::fail("not an engine state");
  if (const auto v = r.value<std::uint32_t>(); v != kStateVersion)
    detail::ByteReader::fail(fmt::format("unsupported version {}", v));
  const auto n = r.value<std::uint64_t>();
  if (n != particles.size())
    detail::ByteReader::fail(
        fmt::format("{} particles in the state, {} in the arrays", n, particles.size()));
  if (r.value<std::uint64_t>() != boundaries_.size() ||
      r.value<std::uint64_t>() != structures_.size() ||
      r.value<std::uint64_t>() != features_.size())
    detail::ByteReader::fail("walls or structures differ from the scene's");
  p_ = std::move(particles);
  r.value(dt_);
  r.value(time_);
  r.value(stats_.steps);
  r.value(stats_.neighbour_rebuilds);
  r.value(stats_.reorders);
  r.value(stats_.structure_updates);
  stats_.pair_entries = r.value<std::uint64_t>();
  stats_.boundary_entries = r.value<std::uint64_t>();
  config_.materials.resize(r.value<std::uint64_t>());
  for (auto& m : config_.materials) {
    r.value(m.mu_s);
    r.value(m.mu_d);
  }
  for (auto& b : boundaries_) {
    b.active = r.value<std::uint8_t>() != 0;
    r.value(b.reaction_x);
    r.value(b.reaction_z);
  }
  r.vec(bvx_);
  r.vec(bvz_);
  r.vec(bvx_ref_);
  r.vec(bvz_ref_);
  if (bvx_.size() != bvx0_.size()) detail::ByteReader::fail("boundary vertex count differs");
  for (auto& st : structures_)
    for (double* v : {&st.ux, &st.uz, &st.rot, &st.vx, &st.vz, &st.omega, &st.soil_fx, &st.soil_fz,
                      &st.soil_moment, &st.applied_fx, &st.applied_fz, &st.applied_moment})
      r.value(*v);
  r.vec(nbr_start_);
  r.vec(nbr_j_);
  read_hist(r, nbr_hist_);
  r.vec(bnd_i_);
  r.vec(bnd_f_);
  read_hist(r, bnd_hist_);
  r.vec(x_ref_);
  r.vec(z_ref_);
  for (double* v : {&skin_, &r_min_, &r_max_, &m_min_}) r.value(*v);
  need_rebuild_ = r.value<std::uint8_t>() != 0;
  r.value(rebuilds_since_reorder_);
  r.value(next_id_);
  for (double* v :
       {&e_friction_, &e_damping_, &e_rebound_, &e_external_, &e_normal_, &e_shear_, &pe_ref_})
    r.value(*v);
  pe_ref_set_ = r.value<std::uint8_t>() != 0;
  if (!r.at_end()) detail::ByteReader::fail("trailing bytes");
  if (nbr_j_.size() != nbr_hist_.size() || bnd_i_.size() != bnd_f_.size() ||
      bnd_i_.size() != bnd_hist_.size() || (!nbr_start_.empty() && nbr_start_.size() != n + 1))
    detail::ByteReader::fail("inconsistent neighbour lists");
  failure_.clear();
}

std::vector<std::byte> Engine::save_contact_history(bool with_boundaries) const {
  // Active entries only, keyed by stable particle ids: (id_i, id_j, history), then
  // (id_i, feature, history).
  detail::ByteWriter w;
  w.value(kHistoryMagic);
  std::vector<std::uint32_t> a, b;
  std::vector<ContactHistory> h;
  for (std::size_t i = 0; i + 1 < nbr_start_.size(); ++i)
    for (std::uint32_t k = nbr_start_[i]; k < nbr_start_[i + 1]; ++k)
      if (nbr_hist_[k].flags != 0) {
        a.push_back(p_.id[i]);
        b.push_back(p_.id[nbr_j_[k]]);
        h.push_back(nbr_hist_[k]);
      }
  w.vec(a);
  w.vec(b);
  write_hist(w, h);
  a.clear();
  b.clear();
  h.clear();
  for (std::size_t k = 0; with_boundaries && k < bnd_i_.size(); ++k)
    if (bnd_hist_[k].flags != 0) {
      a.push_back(p_.id[bnd_i_[k]]);
      b.push_back(bnd_f_[k]);
      h.push_back(bnd_hist_[k]);
    }
  w.vec(a);
  w.vec(b);
  write_hist(w, h);
  return std::move(w.buffer());
}

void Engine::load_contact_history(std::span<const std::byte> blob) {
  detail::ByteReader r(blob);
  if (r.value<std::uint32_t>() != kHistoryMagic) detail::ByteReader::fail("not a contact history");
  std::vector<std::uint32_t> a, b, c, d;
  std::vector<ContactHistory> h, hb;
  r.vec(a);
  r.vec(b);
  read_hist(r, h);
  r.vec(c);
  r.vec(d);
  read_hist(r, hb);
  if (a.size() != b.size() || a.size() != h.size() || c.size() != d.size() || c.size() != hb.size())
    detail::ByteReader::fail("inconsistent contact history");
  const std::size_t n = p_.size();
  std::uint32_t max_id = 0;
  for (std::size_t i = 0; i < n; ++i) max_id = std::max(max_id, p_.id[i]);
  std::vector<std::uint32_t> index(static_cast<std::size_t>(max_id) + 1, ~0u);
  for (std::size_t i = 0; i < n; ++i) index[p_.id[i]] = static_cast<std::uint32_t>(i);
  auto idx = [&](std::uint32_t id) { return id <= max_id ? index[id] : ~0u; };
  // Same layout reorder() leaves: a CSR list of the history entries, merged by rebuild().
  std::vector<std::uint32_t> pi, pj;
  std::vector<ContactHistory> ph;
  for (std::size_t k = 0; k < a.size(); ++k) {
    std::uint32_t u = idx(a[k]), v = idx(b[k]);
    if (u == ~0u || v == ~0u || u == v) continue;
    if (u > v) std::swap(u, v); // swapping the owner flips n and t: f_t is unchanged
    pi.push_back(u);
    pj.push_back(v);
    ph.push_back(h[k]);
  }
  // Store as a CSR list holding only the active pairs; rebuild() merges it.
  store_pairs_csr(n, pi, pj, ph, nbr_start_, nbr_j_, nbr_hist_);
  bnd_i_.clear();
  bnd_f_.clear();
  bnd_hist_.clear();
  std::vector<std::uint32_t> o;
  for (std::size_t k = 0; k < c.size(); ++k)
    if (idx(c[k]) != ~0u && d[k] < features_.size()) o.push_back(static_cast<std::uint32_t>(k));
  std::sort(o.begin(), o.end(), [&](std::uint32_t x, std::uint32_t y) {
    return idx(c[x]) != idx(c[y]) ? idx(c[x]) < idx(c[y]) : d[x] < d[y];
  });
  for (auto k : o) {
    bnd_i_.push_back(idx(c[k]));
    bnd_f_.push_back(d[k]);
    bnd_hist_.push_back(hb[k]);
  }
  need_rebuild_ = true;
}

Engine::MemoryUse Engine::memory_use() const {
  MemoryUse m;
  auto cap = [](const auto& v) {
    return v.capacity() * sizeof(typename std::decay_t<decltype(v)>::value_type);
  };
  m.particles = cap(p_.x) + cap(p_.z) + cap(p_.phi) + cap(p_.vx) + cap(p_.vz) + cap(p_.omega) +
                cap(p_.fx) + cap(p_.fz) + cap(p_.torque) + cap(p_.radius) + cap(p_.mass) +
                cap(p_.inv_mass) + cap(p_.inv_inertia) + cap(p_.id) + cap(p_.material) +
                cap(p_.flags);
  m.contact_history = cap(nbr_hist_) + cap(bnd_hist_);
  m.neighbour_lists =
      cap(nbr_start_) + cap(nbr_j_) + cap(bnd_i_) + cap(bnd_f_) + cap(x_ref_) + cap(z_ref_);
  m.grid = cap(cell_of_) + cap(cell_start_) + cap(cell_items_);
  m.other = cap(tbuf_) + cap(split_) + cap(bvx_) * 6 + cap(features_);
  return m;
}

} // namespace demfem::dem
