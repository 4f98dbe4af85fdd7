#include "demfem/dem/engine.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <type_traits>

#include <fmt/format.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "demfem/dem/stable_step.hpp"

#include "engine_internal.hpp"
#include "integrate_kernel.hpp"

namespace demfem::dem {

using namespace detail;

EngineConfig make_config(const scene::Scene& scene) {
  EngineConfig c;
  if (!scene.soil.dem) return c;
  const auto& d = *scene.soil.dem;
  c.law = contact::make_law(d); // the law of the scene's `contact` and `rolling` (registry.hpp)
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
  xh_ = std::visit([](const auto& law) { return std::decay_t<decltype(law)>::kHistory; },
                   config_.law);
}

std::uint16_t Engine::add_material(Material m) {
  friction_dirty_ = true;
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

void Engine::reserve_particles(std::size_t n) {
  for (auto* v : {&p_.x, &p_.z, &p_.phi, &p_.vx, &p_.vz, &p_.omega, &p_.fx, &p_.fz, &p_.torque,
                  &p_.radius, &p_.mass, &p_.inv_mass, &p_.inv_inertia})
    v->reserve(n);
  p_.id.reserve(n);
  p_.material.reserve(n);
  p_.flags.reserve(n);
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
  friction_dirty_ = true;
  nl_.disp_valid = false;
  compute_mass(i);
  r_min_ = i == 0 ? r : std::min(r_min_, r);
  r_max_ = i == 0 ? r : std::max(r_max_, r);
  m_min_ = i == 0 ? p_.mass[i] : std::min(m_min_, p_.mass[i]);
  nl_.need_rebuild = true;
  return p_.id.back();
}

// A boundary's vertices appended to the vertex arrays (world = reference at creation) and its
// own friction when the scene gives one (default: the soil's, μ_D capped by μ_s).
Boundary Engine::new_boundary(const std::string& name, const std::vector<scene::Vec2>& points,
                              std::optional<double> mu_s, std::optional<double> mu_d) {
  Boundary b;
  b.name = name;
  b.first_vertex = static_cast<std::uint32_t>(bd_.vx.size());
  b.vertex_count = static_cast<std::uint32_t>(points.size());
  if (mu_s || mu_d) {
    b.own_friction = true;
    b.mu_s = mu_s.value_or(config_.materials[0].mu_s);
    b.mu_d = mu_d.value_or(std::min(b.mu_s, config_.materials[0].mu_d));
  }
  for (const auto& q : points) {
    bd_.vx.push_back(q.x);
    bd_.vz.push_back(q.z);
    bd_.vx0.push_back(q.x);
    bd_.vz0.push_back(q.z);
  }
  return b;
}

int Engine::add_wall(const std::vector<scene::Vec2>& points, const std::string& name,
                     const double* mu_s, const double* mu_d) {
  Boundary b = new_boundary(name, points, mu_s ? std::optional<double>(*mu_s) : std::nullopt,
                            mu_d ? std::optional<double>(*mu_d) : std::nullopt);
  const auto bi = static_cast<std::uint32_t>(bd_.list.size());
  // Segments, then vertices with their adjacent segments.
  const std::uint32_t n = b.vertex_count;
  const auto seg0 = static_cast<std::int32_t>(bd_.features.size());
  const std::uint32_t nseg = n < 2 ? 0 : n - 1;
  for (std::uint32_t k = 0; k < nseg; ++k)
    bd_.features.push_back({bi, b.first_vertex + k, b.first_vertex + k + 1});
  for (std::uint32_t k = 0; k < n; ++k) {
    Feature f{bi, b.first_vertex + k, b.first_vertex + k};
    if (k > 0) f.adj0 = seg0 + static_cast<std::int32_t>(k) - 1;
    if (k < nseg) f.adj1 = seg0 + static_cast<std::int32_t>(k);
    bd_.features.push_back(f);
  }
  bd_.list.push_back(b);
  nl_.need_rebuild = true;
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
  b.structure = static_cast<int>(bd_.structures.size());
  const auto bi = static_cast<std::uint32_t>(bd_.list.size());
  const std::uint32_t n = b.vertex_count;
  const auto seg0 = static_cast<std::int32_t>(bd_.features.size());
  for (std::uint32_t k = 0; k < n; ++k)
    bd_.features.push_back({bi, b.first_vertex + k, b.first_vertex + (k + 1) % n});
  for (std::uint32_t k = 0; k < n; ++k) {
    Feature f{bi, b.first_vertex + k, b.first_vertex + k};
    f.adj0 = seg0 + static_cast<std::int32_t>((k + n - 1) % n);
    f.adj1 = seg0 + static_cast<std::int32_t>(k);
    bd_.features.push_back(f);
  }
  st.first_vertex = b.first_vertex;
  st.vertex_count = n;
  st.boundary = bi;
  bd_.list.push_back(b);
  bd_.structures.push_back(st);
  nl_.need_rebuild = true;
  return static_cast<int>(bd_.structures.size() - 1);
}

int Engine::boundary_index(const std::string& name) const {
  for (std::size_t b = 0; b < bd_.list.size(); ++b)
    if (bd_.list[b].name == name) return static_cast<int>(b);
  return -1;
}

int Engine::structure_index(const std::string& name) const {
  for (std::size_t s = 0; s < bd_.structures.size(); ++s)
    if (bd_.structures[s].name == name) return static_cast<int>(s);
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

StepRefused::StepRefused(double dt_, double limit_, std::string formula_, double auto_dt_)
    : std::runtime_error(fmt::format(
          "time step {:.6g} s refused: the stable limit is {:.6g} s ({})", dt_, limit_, formula_)),
      dt(dt_), limit(limit_), auto_dt(auto_dt_), formula(std::move(formula_)) {}

void Engine::set_dt(double dt) {
  const double lim = stable_dt();
  if (!(dt > 0.0) || dt > lim)
    throw StepRefused(dt, lim, critical_step(step_params(config_, m_min_, r_min_)).formula(),
                      auto_dt());
  dt_ = dt;
}

// ---- integration --------------------------------------------------------------------------------

// Integrates particles i0 ≤ i < i1 into `out` (its external work, damping loss, first non-finite
// particle, and the two largest squared displacements since the last rebuild).
void Engine::integrate_range(std::size_t i0, std::size_t i1, double ax_body, double az_body,
                             IntegratedPart& out) {
  const detail::IntegrateConstants c{dt_,     config_.gravity,   ax_body,
                                     az_body, config_.damping_c, config_.damping_d};
  const bool refs = nl_.x_ref.size() == p_.size(); // displacements since the last rebuild
  const detail::IntegrateArrays a{p_.x.data(),
                                  p_.z.data(),
                                  p_.phi.data(),
                                  p_.vx.data(),
                                  p_.vz.data(),
                                  p_.omega.data(),
                                  p_.fx.data(),
                                  p_.fz.data(),
                                  p_.torque.data(),
                                  p_.mass.data(),
                                  p_.inv_mass.data(),
                                  p_.inv_inertia.data(),
                                  refs ? nl_.x_ref.data() : nullptr,
                                  refs ? nl_.z_ref.data() : nullptr};
  const std::uint32_t* __restrict flags = p_.flags.data();
  std::uint32_t removed = 0;
  for (std::size_t i = i0; i < i1; ++i) removed |= flags[i] & kFlagRemoved;
  out.bad = IntegratedPart::kNone;
  if (removed == 0) {
    // No removed particle in the range (the usual case): the vectorised loop; a non-finite state
    // is only flagged there and located here.
    const detail::IntegrateSums s =
        detail::integrate_particles(c, a, i0, i1, detail::kernel_isa(config_.pair_kernel));
    out.work = s.work;
    out.damping = s.damping;
    out.top_a = s.top_a;
    out.top_b = s.top_b;
    if (s.any_bad)
      for (std::size_t i = i0; i < i1 && out.bad == IntegratedPart::kNone; ++i)
        if (!std::isfinite(p_.x[i] + p_.z[i] + p_.omega[i])) out.bad = i;
    return;
  }
  // A removed particle keeps its state (and its displacement: removed particles count in the
  // rebuild test, as in check_rebuild).
  const bool damped = c.C != 0.0 || c.D != 0.0;
  double w_ext = 0.0, e_damp = 0.0;
  detail::Top2 top;
  for (std::size_t i = i0; i < i1; ++i) {
    if (!(flags[i] & kFlagRemoved)) {
      const detail::Advanced<double> r = damped ? detail::advance_particle<true>(c, a, i)
                                                : detail::advance_particle<false>(c, a, i);
      w_ext += r.w;
      e_damp += r.ed;
      if (!std::isfinite(r.s) && out.bad == IntegratedPart::kNone) out.bad = i;
    }
    if (refs) {
      const double dx = p_.x[i] - nl_.x_ref[i], dz = p_.z[i] - nl_.z_ref[i];
      top.add(dx * dx + dz * dz);
    }
  }
  out.work = w_ext;
  out.damping = e_damp;
  out.top_a = top.a;
  out.top_b = top.b;
}

std::pair<double, double> Engine::body_acceleration() const {
  double ax_body = 0.0, az_body = 0.0;
  if (config_.shaking) {
    const double a = config_.shaking_acceleration(time_); // body force m·A·sin(2πft) (paper §6)
    (config_.shaking_direction == 'z' ? az_body : ax_body) = a;
  }
  return {ax_body, az_body};
}

void Engine::integrate() {
  const std::size_t n = p_.size();
  const auto [ax_body, az_body] = body_acceleration();
  std::size_t parts = 1;
  if (fp_.integrated_parts > 0) { // done inside the force loop (contact_forces)
    parts = fp_.integrated_parts;
  } else if (threads_in_use() <= 1) {
    integrate_range(0, n, ax_body, az_body, fp_.integrated[0]);
  } else {
    // The force loop's parts (each particle on the thread that computed its forces: its data is
    // in that core's cache), or equal chunks before the first list; partial sums combined in part
    // order (deterministic per count).
    parts = std::min(static_cast<std::size_t>(threads_in_use()), kMaxParts);
    const bool own = fp_.split.size() == parts + 1 && fp_.split[parts] == n;
    const auto part = [&](std::size_t t) {
      integrate_range(own ? fp_.split[t] : n * t / parts,
                      own ? fp_.split[t + 1] : n * (t + 1) / parts, ax_body, az_body,
                      fp_.integrated[t]);
    };
    if (team_size() <= 1) { // a team of one: no region (see contact_forces)
      for (std::size_t t = 0; t < parts; ++t) part(t);
    } else {
#pragma omp parallel num_threads(team_size())
      {
        const auto [t0, tstride] = team_member();
        for (std::size_t t = t0; t < parts; t += tstride) part(t);
      }
    }
  }
  fp_.integrated_parts = 0;
  std::size_t bad = IntegratedPart::kNone;
  detail::Top2 top;
  for (std::size_t t = 0; t < parts; ++t) {
    en_.external += fp_.integrated[t].work;
    en_.damping += fp_.integrated[t].damping;
    if (bad == IntegratedPart::kNone) bad = fp_.integrated[t].bad;
    top.add(fp_.integrated[t].top_a);
    top.add(fp_.integrated[t].top_b);
  }
  nl_.disp_a = top.a;
  nl_.disp_b = top.b;
  nl_.disp_valid = nl_.x_ref.size() == n;
  if (bad != IntegratedPart::kNone && failure_.empty())
    failure_ = fmt::format("non-finite position or velocity of particle {}", p_.id[bad]);
}

void Engine::update_structures() {
  if (bd_.structures.empty()) return;
  ++stats_.structure_updates;
  const double dt = dt_;
  const double g = config_.gravity;
  const double tn = time_ + dt;
  for (auto& st : bd_.structures) {
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
    en_.external += w;
    (void)vx0;
    (void)vz0;
    (void)om0;
    (void)px;
    (void)pz;
  }
  update_boundary_vertices();
}

void Engine::first_step_setup() {
  if (!(dt_ > 0.0)) set_dt(auto_dt());
  if (!en_.pe_ref_set) {
    en_.pe_ref_set = true;
    en_.pe_ref = 0.0;
    const double g = config_.gravity;
    for (std::size_t i = 0; i < p_.size(); ++i) en_.pe_ref += p_.mass[i] * g * p_.z[i];
    for (const auto& st : bd_.structures)
      if (st.spec.dead_weight) en_.pe_ref += st.mass * g * (st.pz0 + st.uz + st.cz_local);
  }
}

void Engine::prepare() {
  first_step_setup();
  const auto t0 = std::chrono::steady_clock::now();
  // The check the next step would make; that step's own check then finds the particles where
  // this one left them and builds nothing more.
  check_rebuild();
  stats_.rebuild_seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void Engine::step() {
  first_step_setup();
  const auto t0 = std::chrono::steady_clock::now();
  if (!tuner_.started && !tuner_.fixed && config_.adaptive_threads && threads_in_use() > 1)
    start_team(team_clock_ ? team_now() : t0);
  const auto r0 = team_clock_ ? team_now() : t0;
  check_rebuild();
  const auto t1 = std::chrono::steady_clock::now();
  if (tuner_.started) // on the team's clock (tune_team)
    tuner_.rebuild_s += std::chrono::duration<double>((team_clock_ ? team_now() : t1) - r0).count();
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

void Engine::start_team(std::chrono::steady_clock::time_point now) {
  // Start with one thread and probe the full team after the first window (once the idle reading
  // says another CPU is free): a stalled full team is what costs, so it is only ever tried for
  // short probes, and not for the first step, before any measurement. When the CPUs the full
  // team needs are free at this instant, start on the full team instead and probe one thread
  // after the fourth window (a probe of one thread never stalls; a full team that meets a busy
  // core loses that probe).
  auto& tu = tuner_;
  tu.started = true;
  tu.t0 = now;
  tu.steps = 0;
  tu.rebuild_s = 0.0;
  const int need = threads_in_use() - 1;
  const bool free = free_now_ && free_now_() >= need;
  tu.current = free ? 0 : 1;
  team_ = tu.current;
  // The full team's first window carries the thread pool's start: its probe of one thread waits
  // for the fourth window, as after a probe lost.
  tu.probe_every = free ? 4 : 1;
  tu.until_probe = tu.probe_every;
  if (idle_source_) {
    tu.idle_t = now;
    tu.idle_s = idle_source_();
  }
}

void Engine::tune_team() {
  const int T = threads_in_use();
  if (T <= 1) return;
  const bool one = team_size() == 1;
  ++(one ? stats_.team_one_steps : stats_.team_full_steps);
  auto& tu = tuner_;
  if (tu.fixed || !config_.adaptive_threads) return;
  const auto now = team_now();
  if (!tu.started) {
    start_team(now);
    return;
  }
  ++tu.steps;
  // The window's time without the neighbour rebuilds in it: they come every 10²–10³ steps, and
  // one rebuild of 10⁶ disks (0.27 s) in a window of 8 steps of 17 ms tripled its pace, so that
  // the probe of one thread after it "won" and ran 8 steps at half speed
  // (bench/RESULTS.md).
  const double elapsed =
      std::max(0.0, std::chrono::duration<double>(now - tu.t0).count() - tu.rebuild_s);
  // A probe behind the current choice's pace (after at least 8 steps' worth of time, or a
  // quarter window when that is shorter) has lost: stop it now. A stalled team can be 10–50×
  // slower: one scheduler slice of the other process costs several steps, and a probe that waited
  // for a quarter window (32 steps at 10⁴ disks) lost more than the adaptation gained.
  const long grace = std::min<long>(tu.window / 4, 8);
  const bool lost =
      tu.probing &&
      elapsed > tu.current_per_step * static_cast<double>(std::max(tu.steps, grace)) / 0.95;
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
    // A window a quarter slower than the one before (another process took a core the full team
    // uses, say) tries the other choice now instead of after up to 64 windows: a full team that
    // had won for seconds kept running at 0.8–1.3× one thread's pace after `stress-ng --cpu 1`
    // started (10⁵ disks; bench/RESULTS.md).
    const bool slowed = tu.current_per_step > 0.0 && per > 1.25 * tu.current_per_step;
    tu.current_per_step = per;
    if (slowed) tu.until_probe = std::min(tu.until_probe, 1);
    if (--tu.until_probe <= 0) {
      const int idle = tu.current == 1 ? others_idle(now) : 1; // a probe of one thread never stalls
      if (idle > 0) {
        tu.probing = true;
        team_ = tu.current == 1 ? 0 : 1;
      } else if (idle == 0) {
        // the other CPUs were busy: the full team would stall; ask again later
        ++stats_.team_probes_skipped;
        tu.until_probe = tu.probe_every;
      } else { // too short a span to tell: decide after the next window
        tu.until_probe = 1;
      }
    }
  }
  tu.t0 = now;
  tu.steps = 0;
  tu.rebuild_s = 0.0;
}

int Engine::others_idle(std::chrono::steady_clock::time_point now) {
  auto& tu = tuner_;
  if (!idle_source_) return 1;
  const double span = std::chrono::duration<double>(now - tu.idle_t).count();
  // /proc/stat counts in ticks of 10 ms: over less than 5 ticks per CPU the reading says little.
  if (std::isfinite(tu.idle_s) && span < 0.05) return -1;
  const double s = idle_source_();
  const double idle = s - tu.idle_s;
  tu.idle_s = s;
  tu.idle_t = now;
  if (!std::isfinite(idle)) return 1; // unknown (or the first reading): probe, as without a source
  // The full team needs T − 1 more CPUs; it is worth a probe when they were idle at least half
  // of the time (a partly busy core may still win; a fully busy one only stalls the team).
  return idle >= 0.5 * static_cast<double>(threads_in_use() - 1) * span ? 1 : 0;
}

void Engine::run_steps(long long n) {
  run_until(std::numeric_limits<double>::infinity(), n);
}

// ---- events -------------------------------------------------------------------------------------

void Engine::open_wall(const std::string& name) {
  const int b = boundary_index(name);
  if (b < 0) throw std::runtime_error("open_wall: no wall named '" + name + "'");
  bd_.list[static_cast<std::size_t>(b)].active = false;
  nl_.need_rebuild = true;
}

std::size_t Engine::set_friction(const scene::Polygon& region, double mu_s, double mu_d) {
  const std::uint16_t mat = add_material({mu_s, mu_d});
  std::size_t count = 0;
  for (std::size_t i = 0; i < p_.size(); ++i)
    if (scene::contains(region, {p_.x[i], p_.z[i]})) {
      p_.material[i] = mat;
      ++count;
    }
  friction_dirty_ = true;
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
  for (const auto& st : bd_.structures) {
    e.kinetic += 0.5 * st.mass * (st.vx * st.vx + st.vz * st.vz);
    e.rotational += 0.5 * st.inertia * st.omega * st.omega;
    if (st.spec.dead_weight) {
      const double c = std::cos(st.rot), s = std::sin(st.rot);
      pe += st.mass * g * (st.pz0 + st.uz + s * st.cx_local + c * st.cz_local);
    }
  }
  pe += en_.pe_left; // removed particles: at the height where they left
  e.potential = pe - (en_.pe_ref_set ? en_.pe_ref : pe);
  e.gravity_work = -e.potential;
  e.left_scene = en_.left;
  e.spring_normal = en_.normal;
  e.spring_shear = en_.shear;
  e.friction = en_.friction;
  e.damping = en_.damping;
  e.rebound = en_.rebound;
  e.external_work = en_.external;
  return e;
}

std::size_t Engine::pair_contact_count() const {
  std::size_t n = 0;
  for (const auto& h : nl_.hist) n += (h.flags & kHistActive) ? 1 : 0;
  return n;
}

void Engine::contacts(std::vector<ContactView>& out, bool pairs) const {
  out.clear();
  for (std::size_t i = 0; pairs && i + 1 < nl_.start.size(); ++i)
    for (std::uint32_t k = nl_.start[i]; k < nl_.start[i + 1]; ++k) {
      const auto& h = nl_.hist[k];
      if (!(h.flags & kHistActive)) continue;
      const std::uint32_t j = nl_.j[k];
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
  for (std::size_t k = 0; k < nl_.bnd_i.size(); ++k) {
    const auto& h = nl_.bnd_hist[k];
    if (!(h.flags & kHistActive)) continue;
    const auto& F = bd_.features[nl_.bnd_f[k]];
    const std::uint32_t i = nl_.bnd_i[k];
    ContactView v;
    v.i = i;
    v.j = -1 - static_cast<std::int64_t>(F.boundary);
    // Contact point: the closest point of the feature.
    if (F.v0 == F.v1) {
      v.cx = bd_.vx[F.v0];
      v.cz = bd_.vz[F.v0];
    } else {
      const double ax = bd_.vx[F.v0], az = bd_.vz[F.v0];
      const double ex = bd_.vx[F.v1] - ax, ez = bd_.vz[F.v1] - az;
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

std::size_t Engine::overlapping_pair_count() const {
  const double* __restrict x = p_.x.data();
  const double* __restrict z = p_.z.data();
  const double* __restrict rad = p_.radius.data();
  std::size_t n = 0;
  for (std::size_t i = 0; i + 1 < nl_.start.size(); ++i) {
    const double xi = x[i], zi = z[i], ri = rad[i];
    for (std::uint32_t k = nl_.start[i]; k < nl_.start[i + 1]; ++k) {
      const std::uint32_t j = nl_.j[k];
      const double dx = xi - x[j], dz = zi - z[j], rs = ri + rad[j];
      n += dx * dx + dz * dz <= rs * rs ? 1u : 0u;
    }
  }
  return n;
}

double Engine::largest_overlap_ratio() const {
  double worst = 0.0;
  const double* __restrict x = p_.x.data();
  const double* __restrict z = p_.z.data();
  const double* __restrict rad = p_.radius.data();
  for (std::size_t i = 0; i + 1 < nl_.start.size(); ++i)
    for (std::uint32_t k = nl_.start[i]; k < nl_.start[i + 1]; ++k) {
      if (!(nl_.hist[k].flags & kHistActive)) continue;
      const std::uint32_t j = nl_.j[k];
      const double dx = x[i] - x[j], dz = z[i] - z[j];
      const double d2 = dx * dx + dz * dz, rsum = rad[i] + rad[j], rmin = std::min(rad[i], rad[j]);
      // (r_i + r_j − d)/r_min ≤ worst when d ≥ r_i + r_j − worst·r_min: skipped without the root
      // when d² clears that by a relative 1e-9, far above round-off (the maximum is the same)
      const double c = rsum - worst * rmin;
      if (c > 0.0 && d2 >= c * c * (1.0 + 1e-9)) continue;
      worst = std::max(worst, (rsum - std::sqrt(d2)) / rmin); // δ (eq. 2.3)
    }
  std::visit(
      [&](const auto& law) {
        for (std::size_t k = 0; k < nl_.bnd_i.size(); ++k) {
          const auto& h = nl_.bnd_hist[k];
          const double fn = h.fn, ri = rad[nl_.bnd_i[k]];
          if ((h.flags & kHistActive) && fn > 0.0) // the law's δ(f_n), R* = r_i at a boundary
            worst = std::max(worst, law.overlap(fn, ri) / ri);
        }
      },
      config_.law);
  return worst;
}

void Engine::boundary_vertices(int b, std::vector<scene::Vec2>& out) const {
  out.clear();
  const auto& B = bd_.list[static_cast<std::size_t>(b)];
  for (std::uint32_t k = B.first_vertex; k < B.first_vertex + B.vertex_count; ++k)
    out.push_back({bd_.vx[k], bd_.vz[k]});
}

void Engine::boundary_views(std::vector<BoundaryView>& out) const {
  out.clear();
  for (const auto& B : bd_.list) {
    BoundaryView v;
    v.name = B.name;
    v.closed = B.closed;
    v.open = !B.active;
    for (std::uint32_t k = B.first_vertex; k < B.first_vertex + B.vertex_count; ++k) {
      v.x.push_back(bd_.vx[k]);
      v.z.push_back(bd_.vz[k]);
    }
    out.push_back(std::move(v));
  }
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
  m.contact_history = cap(nl_.hist) + cap(nl_.bnd_hist) + cap(nl_.xh) + cap(nl_.bnd_xh);
  m.neighbour_lists = cap(nl_.start) + cap(nl_.j) + cap(nl_.owner) + cap(nl_.bnd_i) +
                      cap(nl_.bnd_f) + cap(nl_.x_ref) + cap(nl_.z_ref);
  m.grid = cap(nl_.cell_of) + cap(nl_.cell_start) + cap(nl_.cell_items);
  m.other =
      cap(fp_.tbuf) + cap(fp_.split) + cap(fp_.halo_end) + cap(bd_.vx) * 6 + cap(bd_.features);
  return m;
}

} // namespace demfem::dem
