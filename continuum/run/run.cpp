// Scene-driven continuum run: maps a Scene onto fem::Problem, initialises gravity, integrates the
// scene's duration (Newmark-β or explicit central differences) and calls its hooks between steps
// (run/hooks.hpp): probes, steps.csv, snapshots, the small-strain watch, progress. The files it
// writes under <out>/continuum and their columns are the run-directory contract's
// (output/contract.hpp).
//
// Modelling choices (see continuum/README.md):
// - mesh: tensor-product grid through every vertex coordinate of the domain and the structures,
//   coarse size min(width, height)/4, refined `refinement` times; cells whose centre lies outside
//   the domain and all structures are removed (stair-stepped inclined boundaries);
// - structures are rigid bodies tied to the soil: every dof of their cells follows the pivot's
//   (ux, uz, θ), each fixed, free or prescribed as the scene says; their external force/moment
//   histories act as body forces with the same resultant and moment; a structure held
//   vertically and embedded is first seated on the soil under its weight
//   (continuum.seat_structures); with
//   continuum.interface = "frictional" the soil cells touching a structure form a thin
//   Mohr–Coulomb layer of wall friction δ (continuum.interface_friction_angle);
// - soil: the domain polygon below soil.continuum.surface when given;
// - boundaries: sides on rollers, base fixed.
#include "demfem/continuum/run.hpp"

#include <fmt/format.h>

#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <optional>
#include <set>

#include "constitutive/registry.hpp"
#include "constitutive/soil.hpp"
#include "demfem/output/contract.hpp"
#include "demfem/output/probe.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/validate.hpp"
#include "demfem/scene/write_file.hpp"
#include "fem.hpp"
#include "hooks.hpp"
#include "mesh_grading.hpp"

namespace demfem::continuum {
namespace {

std::vector<double> steps_through(std::set<double> breaks, double h) {
  std::vector<double> out;
  std::vector<double> b(breaks.begin(), breaks.end());
  for (std::size_t i = 0; i + 1 < b.size(); ++i) {
    const double len = b[i + 1] - b[i];
    if (len <= 1e-9 * h) continue;
    const int n = std::max(1, static_cast<int>(std::ceil(len / h - 1e-9)));
    for (int k = 0; k < n; ++k) out.push_back(len / n);
  }
  return out;
}

double top_of(const scene::Polygon& poly, double x, double fallback) {
  double top = -1e300;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const auto& a = poly[i];
    const auto& b = poly[j];
    if ((a.x <= x && b.x >= x) || (b.x <= x && a.x >= x)) {
      const double z = std::abs(b.x - a.x) < 1e-300 ? std::max(a.z, b.z)
                                                    : a.z + (b.z - a.z) * (x - a.x) / (b.x - a.x);
      top = std::max(top, z);
    }
  }
  return top > -1e299 ? top : fallback;
}

// The part of `poly` below z = level (Sutherland & Hodgman 1974, one clipping edge).
scene::Polygon clip_below(const scene::Polygon& poly, double level) {
  scene::Polygon out;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const auto& a = poly[i];
    const auto& b = poly[(i + 1) % poly.size()];
    const bool ain = a.z <= level, bin = b.z <= level;
    if (ain) out.push_back(a);
    if (ain != bin) {
      const double f = (level - a.z) / (b.z - a.z);
      out.push_back({a.x + f * (b.x - a.x), level});
    }
  }
  return out;
}

// The scene with its structures where the DEM packing seated them (calibrate = "dem";
// ContinuumSoil::structure_offsets), so both models hold a foundation at the same height.
scene::Scene seated(const scene::Scene& scene_in) {
  scene::Scene s = scene_in;
  if (s.soil.continuum)
    for (const auto& [name, dz] : s.soil.continuum->structure_offsets)
      for (auto& st : s.structures)
        if (st.name == name) st = scene::shifted(st, dz);
  return s;
}

// The friction a DEM particle meets on a wall or structure (dem/src/engine.cpp, new_boundary and
// the particle–boundary contact): the boundary's own mu_static/mu_dynamic (μ_d defaulting to
// min(μ_s, the soil's μ_d)), else the particle's: the last set-friction event at t ≤ 0 on a group
// covering the whole domain, else [soil.dem]'s. Empty when the scene has no DEM soil to take it
// from and the boundary states none.
std::optional<std::pair<double, double>>
dem_friction(const scene::Scene& scene, std::optional<double> mu_s, std::optional<double> mu_d) {
  std::optional<std::pair<double, double>> soil;
  if (scene.soil.dem) soil = std::pair{scene.soil.dem->mu_static, scene.soil.dem->mu_dynamic};
  double t_event = -1e300;
  for (const auto& ev : scene.events) {
    if (ev.action != scene::EventAction::SetFriction || ev.time > 0.0 || ev.time < t_event)
      continue;
    const scene::Group* g = scene.group(ev.group);
    if (!g) continue;
    bool covers = true;
    for (const auto& p : scene.domain) covers = covers && scene::contains(g->region, p);
    if (!covers) continue;
    soil = std::pair{ev.mu_static, ev.mu_dynamic};
    t_event = ev.time;
  }
  if (mu_s || mu_d) {
    if (!soil && !mu_s) return std::nullopt;
    const double s = mu_s.value_or(soil ? soil->first : 0.0);
    return std::pair{s, mu_d.value_or(std::min(s, soil ? soil->second : s))};
  }
  return soil;
}

// Contact planes (continuum.interface = "coulomb") along the axis-aligned segments of a wall's
// polyline or a structure's closed outline, with the friction the DEM particles meet there
// (dem_friction); inclined segments get none. `region`: the structure's index, −1 for a wall.
// False (with `message`) when the scene gives no friction to take.
bool add_contact_planes(const scene::Scene& scene, const std::string& kind, const std::string& name,
                        const std::vector<scene::Vec2>& points, bool closed,
                        std::optional<double> mu_s, std::optional<double> mu_d, int region,
                        double tol, fem::Problem& pb, std::string& message) {
  const auto mu = dem_friction(scene, mu_s, mu_d);
  if (!mu) {
    message = fmt::format("continuum.interface = \"coulomb\" takes the friction of {} '{}' from "
                          "the DEM: give its mu_static/mu_dynamic or a [soil.dem] section",
                          kind, name);
    return false;
  }
  const std::size_t n = points.size(), segments = closed ? n : (n > 0 ? n - 1 : 0);
  for (std::size_t k = 0; k < segments; ++k) {
    const auto &a = points[k], &b = points[(k + 1) % n];
    if (std::abs(a.x - b.x) > tol && std::abs(a.z - b.z) > tol) continue; // inclined: none
    fem::ContactPlane cp;
    cp.name = name;
    cp.a = {a.x, a.z};
    cp.b = {b.x, b.z};
    cp.mu_static = mu->first;
    cp.mu_dynamic = mu->second;
    cp.region = region;
    pb.contacts.push_back(cp);
  }
  return true;
}

// The finite-element problem of a (seated) scene: mesh, materials, structures, loads and
// procedures. Returns false with `message` when the scene cannot be meshed.
struct Setup {
  fem::Problem pb;
  scene::Polygon domain; // the continuum soil
  double xmin = 1e300, xmax = -1e300, zmin = 1e300, zmax = -1e300;
};
bool build_problem(const scene::Scene& scene, const RunOptions& options, Setup& su,
                   std::string& message) {
  if (!scene.soil.continuum) {
    message = "the scene has no [soil.continuum] section";
    return false;
  }
  if (scene.domain.size() < 3) {
    message = "the scene has no domain polygon";
    return false;
  }
  const scene::ContinuumSoil& soil = *scene.soil.continuum;
  const scene::ContinuumOptions& co = scene.continuum;
  // the continuum soil: the domain polygon, below the ground surface when one is given
  scene::Polygon& domain = su.domain;
  domain = scene.domain;
  if (soil.surface) {
    domain = clip_below(scene.domain, *soil.surface);
    if (domain.size() < 3 || std::abs(scene::signed_area(domain)) <= 0.0) {
      message = fmt::format("soil.continuum.surface = {} m leaves no soil in the domain "
                            "polygon; give a height above its lowest point",
                            *soil.surface);
      return false;
    }
  }

  fem::Problem& pb = su.pb;
  // ---- mesh
  std::set<double> xs, zs;
  double &xmin = su.xmin, &xmax = su.xmax, &zmin = su.zmin, &zmax = su.zmax;
  auto add = [&](const scene::Vec2& p) {
    xs.insert(p.x);
    zs.insert(p.z);
    xmin = std::min(xmin, p.x);
    xmax = std::max(xmax, p.x);
    zmin = std::min(zmin, p.z);
    zmax = std::max(zmax, p.z);
  };
  for (const auto& p : scene.domain) add(p);
  for (const auto& p : domain) add(p);
  for (const auto& s : scene.structures)
    for (const auto& p : s.outline) add(p);
  const double h0 = std::min(xmax - xmin, zmax - zmin) / 4.0;
  pb.mesh.x0 = xmin;
  pb.mesh.z0 = zmin;
  if (co.mesh_size_near > 0.0 && !scene.structures.empty()) {
    // graded towards the structures' bounding box (continuum.mesh_size_near, mesh_grading)
    double bx0 = 1e300, bx1 = -1e300, bz0 = 1e300, bz1 = -1e300;
    for (const auto& s : scene.structures)
      for (const auto& p : s.outline) {
        bx0 = std::min(bx0, p.x);
        bx1 = std::max(bx1, p.x);
        bz0 = std::min(bz0, p.z);
        bz1 = std::max(bz1, p.z);
      }
    const double hn = std::min(co.mesh_size_near, h0);
    pb.mesh.dx = graded_steps_through(xs, h0, hn, co.mesh_grading, bx0, bx1);
    pb.mesh.dz = graded_steps_through(zs, h0, hn, co.mesh_grading, bz0, bz1);
  } else {
    pb.mesh.dx = steps_through(xs, h0);
    pb.mesh.dz = steps_through(zs, h0);
  }
  for (const auto& p : domain) pb.mesh.domain.push_back({p.x, p.z});
  pb.mesh.refinement = options.refinement >= 0 ? options.refinement : co.refinement;
  pb.degree = options.degree >= 1 ? options.degree : co.degree;
  pb.bbar = co.bbar;

  // ---- materials
  // the soil's model, chosen by its keyword with its parameter blocks (constitutive/registry.hpp)
  pb.soil = constitutive::Material::from(constitutive::soil_model(soil));
  pb.density = soil.density;
  if (pb.soil.stiffness_from_stress()) {
    // E = young (p/p_ref)^n (scene.hpp, constitutive/elastic.hpp), capped at the deepest
    // geostatic in-plane mean stress ρ g H (1 + K0)/2 (the explicit step is bounded with it)
    const double k0 = constitutive::soil_k0(soil);
    double zlo = 1e300, zhi = -1e300;
    for (const auto& p : domain) {
      zlo = std::min(zlo, p.z);
      zhi = std::max(zhi, p.z);
    }
    const double p_max = soil.density * scene.load.gravity * std::max(zhi - zlo, 0.0) * 0.5 *
                         (1.0 + std::max(k0, 1.0));
    pb.soil.cap_stiffness_at(p_max);
  }
  for (const auto& s : scene.structures) {
    fem::Region r;
    r.name = s.name;
    for (const auto& p : s.outline) r.outline.push_back({p.x, p.z});
    r.material.young = 1000.0 * pb.soil.elasticity().hooke.young; // "very stiff" elastic body
    r.material.poisson = 0.2;
    const double area = std::abs(scene::signed_area(s.outline));
    r.density = s.mass > 0.0 && area > 0.0 ? s.mass / area : s.density;
    r.force_x = s.force_x;
    r.force_z = s.force_z;
    r.moment = s.moment;
    r.load_point = {s.load_point.x, s.load_point.z};
    r.pivot = {s.pivot.x, s.pivot.z};
    // rigid body honouring the structure's DoF modes (fixed / free / prescribed about the pivot)
    r.rigid = true;
    const scene::DofMode modes[3] = {s.dof_x, s.dof_z, s.dof_rotation};
    const scene::TimeFunction* motion[3] = {&s.motion_x, &s.motion_z, &s.motion_rotation};
    for (int k = 0; k < 3; ++k) {
      r.mode[k] = modes[k] == scene::DofMode::Fixed  ? fem::Region::Mode::Fixed
                  : modes[k] == scene::DofMode::Free ? fem::Region::Mode::Free
                                                     : fem::Region::Mode::Prescribed;
      r.motion[k] = *motion[k];
    }
    r.dead_weight = s.dead_weight;
    // seated on the soil before t = 0 (continuum.seat_structures, scene.hpp): held vertically and
    // with soil below it (absent: and on both sides, i.e. embedded, as the DEM packing seats it)
    if (s.dof_z == scene::DofMode::Fixed && co.seat_structures.value_or(true)) {
      double sx0 = 1e300, sx1 = -1e300, sz0 = 1e300;
      for (const auto& p : s.outline) {
        sx0 = std::min(sx0, p.x);
        sx1 = std::max(sx1, p.x);
        sz0 = std::min(sz0, p.z);
      }
      double dx0 = 1e300, dx1 = -1e300, dz0 = 1e300;
      for (const auto& p : domain) {
        dx0 = std::min(dx0, p.x);
        dx1 = std::max(dx1, p.x);
        dz0 = std::min(dz0, p.z);
      }
      const double tol = 1e-9 * std::max(xmax - xmin, zmax - zmin);
      const bool below = sz0 > dz0 + tol && sx1 > dx0 + tol && sx0 < dx1 - tol;
      const bool sides = sx0 > dx0 + tol && sx1 < dx1 - tol &&
                         top_of(domain, sx0 - 1e3 * tol, dz0) > sz0 + tol &&
                         top_of(domain, sx1 + 1e3 * tol, dz0) > sz0 + tol;
      r.seat = below && (co.seat_structures.has_value() || sides);
    }
    // continuum.interface = "coulomb": a structure is a rigid body in zero-thickness Coulomb
    // contact with the soil instead of sharing its nodes: not meshed, each axis-aligned outline
    // edge a contact plane with the friction the DEM particles meet on it (dem_friction). One that
    // never moves (every DoF fixed, e.g. the retaining wall) always; a moving one (the rocking
    // foundation) unless continuum.structure_interface = "tied". One that never moves is not
    // seated (its contact nodes hold the soil in the K0 state); a moving one held vertically is
    // seated as a tied one (Region::seat; the nodes on its faces follow it down until the soil
    // carries its weight).
    const bool at_rest = s.dof_x == scene::DofMode::Fixed && s.dof_z == scene::DofMode::Fixed &&
                         s.dof_rotation == scene::DofMode::Fixed;
    if (co.interface == "coulomb" && (at_rest || co.structure_interface == "contact")) {
      r.contact = true;
      if (at_rest) r.seat = false;
      if (!add_contact_planes(scene, "structure", s.name, s.outline, true, s.mu_static,
                              s.mu_dynamic, static_cast<int>(pb.regions.size()),
                              1e-9 * std::max(xmax - xmin, zmax - zmin), pb, message))
        return false;
    }
    pb.regions.push_back(r);
  }
  // ---- soil–structure interface
  if (co.interface == "frictional") {
    // Thin-layer interface: a layer with friction angle φ_l and ψ = 0 fails in simple shear at
    // τ/σn = sin φ_l (Davis 1968, non-associated flow), so sin φ_l = tan δ gives a wall/base
    // friction angle δ.
    const double mu = std::tan(co.interface_friction_angle);
    if (mu >= 1.0) {
      message = fmt::format(
          "continuum.interface_friction_angle = {:.4g}°: the thin-layer interface needs δ < 45° "
          "(its layer friction angle is asin(tan δ))",
          co.interface_friction_angle * 180.0 / std::numbers::pi);
      return false;
    }
    pb.interface_friction = std::asin(mu);
    pb.interface_cohesion = 0.0;
  }
  // ---- Coulomb contact with the DEM's walls (continuum.interface = "coulomb"): every
  // axis-aligned segment of a [[wall]] is a rigid plane at rest in the shaking frame; the soil's
  // boundary faces on it slide and separate with the friction the DEM particles meet there
  // (dem_friction). Boundaries without a wall keep their box condition (sides rollers, base fixed).
  if (co.interface == "coulomb") {
    for (const auto& w : scene.walls)
      if (!add_contact_planes(scene, "wall", w.name, w.points, false, w.mu_static, w.mu_dynamic, -1,
                              1e-9 * std::max(xmax - xmin, zmax - zmin), pb, message))
        return false;
  }
  // ---- loads and procedures
  pb.gravity = scene.load.gravity;
  if (scene.load.shaking) {
    pb.shaking_component = scene.load.shaking->direction == 'z' ? 1 : 0;
    pb.shaking = scene.load.shaking->acceleration;
  }
  pb.linear_solver = co.linear_solver;
  pb.newton_tolerance = co.newton_tolerance;
  pb.newton_max_iterations = co.newton_max_iterations;
  pb.newmark_beta = co.newmark_beta;
  pb.newmark_gamma = co.newmark_gamma;
  pb.rayleigh_alpha = co.rayleigh_alpha;
  pb.rayleigh_beta = co.rayleigh_beta;
  pb.absorbing = co.absorbing;
  // diagnostics (continuum/README.md), read here so that the solver itself reads no environment
  pb.newton_trace = std::getenv("DEMFEM_NEWTON_TRACE") != nullptr;
  pb.tangent_check = std::getenv("DEMFEM_TANGENT_CHECK") != nullptr;
  pb.integrator = co.integrator;
  pb.explicit_safety = co.explicit_safety;
  pb.local_damping = co.local_damping;
  if (co.integrator == "explicit") pb.explicit_dt = co.dt; // 0 = automatic
  return true;
}

// The explicit step limit of a prepared problem, for messages and the scene check.
scene::ContinuumStepLimit step_limit(const Setup& su, const scene::Scene& scene) {
  const fem::Problem& pb = su.pb;
  scene::ContinuumStepLimit lim;
  lim.dt = fem::stable_time_step(pb);
  lim.formula = fmt::format(
      "explicit_safety {} × 2/ω_max, ω_max bounded by the largest element eigenvalue (Irons "
      "1970) of the refinement-{} Q{} mesh, E = {:.4g} Pa, ν = {:.3g}, ρ = {:.4g} kg/m³{}",
      pb.explicit_safety, pb.mesh.refinement, pb.degree, pb.soil.elasticity().hooke.young,
      pb.soil.elasticity().hooke.poisson, pb.density,
      scene.soil.continuum && scene.soil.continuum->calibrate_dem ? " (calibrated)" : "");
  return lim;
}

} // namespace

std::optional<scene::ContinuumStepLimit> stable_step(const scene::Scene& scene_in,
                                                     const RunOptions& options) {
  const scene::Scene scene = seated(scene_in);
  Setup su;
  std::string message;
  if (!build_problem(scene, options, su, message)) return std::nullopt;
  fem::ensure_mpi();
  return step_limit(su, scene);
}

namespace {

// The probes with the DEM's names, signs and units (output/contract.hpp): the root writes them,
// every rank samples (the source's calls are collective).
// A resumed run keeps the rows up to its checkpoint's time (half a loop step beyond it: the time
// column has 6 digits) and rewrites the rest.
output::ProbeSetOptions probe_options(const scene::Scene& scene, bool root,
                                      const run_detail::Checkpoint* from) {
  output::ProbeSetOptions o;
  o.base_interval = scene.output.probe_interval;
  o.csv.flush_every_rows = 50;
  o.csv.formats = {output::CsvFormat::general(6)}; // time
  o.csv.keep_errors = true;
  if (from) o.csv.resume_after = from->time + 0.5 * from->dt;
  o.write = root;
  o.load_histories = true;
  return o;
}

// An explicit run writes a checkpoint at least this often [s of wall time], so that a kill
// without a stop signal (SIGKILL, a power cut) loses at most this much of a long run.
constexpr double kCheckpointWallSeconds = 600.0;

// One run's model and hooks (run/hooks.hpp), set up in this order.
class Driver {
public:
  // `from`: the checkpoint a resumed run continues from (null: from t = 0).
  Driver(const scene::Scene& scene, const fem::Problem& pb, const std::filesystem::path& dir,
         bool root, std::string identity, const run_detail::Checkpoint* from)
      : m(pb), snapshots(m, scene, dir), scene_(scene), pb_(pb), dir_(dir), root_(root),
        identity_(std::move(identity)), from_(from), source_(m, scene),
        probes_(scene, source_, probe_options(scene, root, from), from ? &from->probes : nullptr),
        checkpoint_interval_(scene.output.checkpoint_interval),
        next_checkpoint_(scene.output.checkpoint_interval) {}

  // log.txt's head, gravity, the K0 state and the seating; the loop's step; the files and the
  // state at t = 0, or a resumed run's state from its checkpoint (the same initialisation first:
  // the constraints, loads and masses it sets are the checkpoint's). Returns "" or why the run
  // cannot go on.
  std::string start(RunSummary& summary, std::chrono::steady_clock::time_point t_start) {
    using namespace run_detail;
    describe(summary, m, pb_);
    if (root_) {
      log_.open(dir_ / output::file::log, from_ != nullptr);
      if (from_)
        log_ << fmt::format("resumed from {} at t = {:.6g} s (step {} of {})\n",
                            checkpoint_path(dir_, 0).string(), from_->time, from_->step,
                            from_->nsteps);
      log_header(log_, scene_, m, pb_);
    }
    if (auto why = initialise(m, scene_, pb_, log_, root_, summary, t_start); !why.empty())
      return why;
    if (root_ && !probes_.not_recorded().empty())
      log_ << fmt::format("probes the continuum does not record: {}\n",
                          fmt::join(probes_.not_recorded(), "; "));
    dt = loop_step(m, scene_, probes_.finest_interval(), log_, root_, summary, nsteps);
    if (from_) {
      if (from_->nsteps != nsteps || from_->dt != dt)
        return fmt::format("cannot resume from {}: it has {} steps of {:.6g} s, this run {} of "
                           "{:.6g} s",
                           checkpoint_path(dir_, fem::MpiScope::rank()).string(), from_->nsteps,
                           from_->dt, nsteps, dt);
      m.restore_explicit_state(from_->model);
      snapshots.restore(from_->snapshots);
      totals_.newton = from_->newton;
      totals_.linear = from_->linear;
      totals_.cuts = from_->cuts;
      totals_.substeps = from_->substeps;
      next_checkpoint_ = from_->next_checkpoint;
      first_step = from_->step + 1;
    }
    probes_.open(dir_);
    if (root_) steps_.open(dir_, from_ ? from_->step : -1);
    if (!from_) {
      snapshots.write(0.0);
      sample(0.0, false);
    }
    raise(); // a file that could not be opened or truncated
    t_dyn_ = std::chrono::steady_clock::now();
    return {};
  }

  // The checkpoint after step `step` (explicit integrator): at output.checkpoint_interval of
  // simulated time, after kCheckpointWallSeconds of wall time since the last one (the root's clock:
  // every rank writes after the same step), and when `now` (a stop). Every output's rows so far
  // are flushed first, so that a resume keeps them.
  void checkpoint(long long step, bool now) {
    const double t = m.time();
    const bool due = checkpoint_interval_ > 0.0 && t >= next_checkpoint_ - 1e-9 * dt;
    const auto wall = std::chrono::steady_clock::now();
    const bool late = fem::MpiScope::any(
        root_ &&
        std::chrono::duration<double>(wall - last_checkpoint_).count() >= kCheckpointWallSeconds);
    if (!due && !now && !late) return;
    last_checkpoint_ = wall;
    while (checkpoint_interval_ > 0.0 && t >= next_checkpoint_ - 1e-9 * dt)
      next_checkpoint_ += checkpoint_interval_;
    probes_.flush();
    steps_.flush();
    log_.flush();
    raise();
    run_detail::Checkpoint c;
    c.identity = identity_;
    c.step = step;
    c.nsteps = nsteps;
    c.dt = dt;
    c.time = t;
    c.next_checkpoint = next_checkpoint_;
    c.probes = probes_.state();
    c.snapshots = snapshots.state();
    c.newton = totals_.newton;
    c.linear = totals_.linear;
    c.cuts = totals_.cuts;
    c.substeps = totals_.substeps;
    c.model = m.explicit_state();
    std::string failure;
    try {
      run_detail::write_checkpoint(run_detail::checkpoint_path(dir_, fem::MpiScope::rank()), c);
    } catch (const scene::WriteError& e) {
      failure = e.what();
    }
    if (fem::MpiScope::any(!failure.empty()))
      throw scene::WriteError(failure.empty() ? "a checkpoint could not be written on another "
                                                "MPI rank"
                                              : failure);
    if (root_)
      log_ << fmt::format("checkpoint at t = {:.6g} s (step {} of {})\n", t, step, nsteps)
           << std::flush;
  }

  // Every row written so far on the disk (a stopped run's outputs end at its last step).
  void flush() {
    probes_.flush();
    steps_.flush();
    log_.flush();
    raise();
  }

  // One step and its record; false (summary says why) when it did not converge.
  bool advance(long long step, RunSummary& summary) {
    const auto t_step = std::chrono::steady_clock::now();
    const fem::StepStats st = m.dynamic_step(dt);
    steps_.add(step, m.time(), st,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t_step).count());
    totals_.add(st);
    if (root_ && (st.cuts > 0 || st.newton_iterations > 10))
      log_ << fmt::format("step {} (t = {:.4g} s): {} Newton iterations, {} cuts\n", step, m.time(),
                          st.newton_iterations, st.cuts)
           << std::flush;
    if (st.converged) return true;
    summary.message =
        fmt::format("{} at t = {:.6g} s\n{}",
                    scene_.continuum.integrator == "explicit" ? "explicit integration diverged"
                                                              : "Newton did not converge",
                    m.time(), m.log());
    summary.steps = step;
    summary.simulated_time = m.time();
    return false;
  }

  // The probes due at t (all at the last step), then the collective check of the writes.
  void sample(double t, bool all) {
    if (!all && !probes_.any_due(t, 1e-9 * dt)) return;
    source_.begin(t);
    probes_.sample_due(source_, 1e-9 * dt, all);
    raise();
  }

  // The small-strain validity limit (continuum.max_displacement): true when the run stops at t,
  // with every probe and a snapshot at t.
  bool beyond_validity(double t, RunSummary& summary) {
    const auto over = run_detail::beyond_small_strain(m, scene_);
    if (over.empty()) return false;
    source_.begin(t);
    probes_.sample_missing(source_);
    raise();
    snapshots.write_if_missed(t);
    summary.note = fmt::format(
        "stopped at t = {:.4g} s of {:.4g} s: {} > continuum.max_displacement = {:.4g} m "
        "(beyond the small-strain model's validity)",
        t, scene_.info.duration, over, scene_.continuum.max_displacement);
    if (root_) log_ << summary.note << "\n";
    return true;
  }

  // The .pvd, surface_profile.csv (the soil's top), the log's last lines; every file closed.
  void finish(RunSummary& summary, std::span<const fem::Point> top) {
    snapshots.finish();
    raise(); // a failed steps.csv row or log line since the last probe row
    const std::string failure = run_detail::write_surface_profile(m, top, dir_, root_);
    if (root_ && !failure.empty()) log_ << "run failed: " << failure << "\n" << std::flush;
    if (fem::MpiScope::any(!failure.empty()))
      throw scene::WriteError(failure.empty() ? "surface_profile.csv: failed on the root rank"
                                              : failure);
    run_detail::log_end(log_, m, pb_, root_, summary, totals_, dt,
                        scene_.continuum.integrator == "explicit", t_dyn_);
    probes_.close();
    steps_.close();
    log_.close();
    raise();
    summary.ok = true;
    summary.simulated_time = m.time();
    summary.substeps = totals_.substeps;
    summary.message = fmt::format("{} steps, {} dofs", summary.steps, m.n_dofs());
  }

  fem::Model m;
  run_detail::Snapshots snapshots;
  double dt = 0.0;
  long long nsteps = 0;
  long long first_step = 1; // a resumed run's: the step after its checkpoint's

private:
  // Collective: the first failed write of any output ends the run on every rank, naming the
  // file and the cause (and it goes to log.txt when that is still writable).
  void raise() {
    std::string failure = probes_.error();
    for (const std::string& e : {steps_.error(), log_.error()})
      if (failure.empty()) failure = e;
    if (!fem::MpiScope::any(!failure.empty())) return;
    if (root_) log_ << "run failed: " << failure << "\n" << std::flush;
    throw scene::WriteError(failure.empty() ? "an output could not be written on the root rank"
                                            : failure);
  }

  const scene::Scene& scene_;
  const fem::Problem& pb_;
  std::filesystem::path dir_;
  bool root_;
  std::string identity_;
  const run_detail::Checkpoint* from_;
  run_detail::CheckedStream log_;
  run_detail::ContinuumProbeSource source_;
  output::ProbeSet probes_;
  run_detail::StepRecord steps_;
  run_detail::Totals totals_;
  double checkpoint_interval_, next_checkpoint_;
  std::chrono::steady_clock::time_point t_dyn_, last_checkpoint_ = std::chrono::steady_clock::now();
};

} // namespace

namespace {

// Where a resumed run starts: its checkpoint (every rank reads its own; all must hold the same
// step), or t = 0 with a note when there is none to continue from (none written yet, or the
// implicit integrator, which writes none). A checkpoint of another scene or mesh is refused
// (scene::SceneError, naming the first line that differs); an unreadable one ends the run ("").
std::string resume_point(const scene::Scene& scene, bool explicit_dyn,
                         const std::filesystem::path& dir, const std::string& identity,
                         std::optional<run_detail::Checkpoint>& from, RunSummary& summary) {
  const int rank = fem::MpiScope::rank();
  const auto path = run_detail::checkpoint_path(dir, rank);
  if (!explicit_dyn) {
    summary.resume_note = "the implicit integrator writes no checkpoint: the continuum run "
                          "starts again from t = 0";
    return {};
  }
  std::string why;
  try {
    from = run_detail::read_checkpoint(path);
  } catch (const std::exception& e) {
    why = fmt::format("cannot resume: {}", e.what());
  }
  if (fem::MpiScope::any(!why.empty()))
    return why.empty() ? "cannot resume: another MPI rank cannot read its checkpoint" : why;
  const bool none = !from.has_value();
  if (fem::MpiScope::any(none)) {
    if (!fem::MpiScope::any(!none)) { // no rank has one: nothing written yet
      summary.resume_note = fmt::format("no continuum checkpoint ({}): the continuum run starts "
                                        "from t = 0",
                                        path.string());
      return {};
    }
    return fmt::format("cannot resume: {} {}, while another MPI rank has its checkpoint",
                       path.string(), none ? "is missing" : "exists");
  }
  const auto d = run_detail::identity_difference(identity, from->identity);
  if (fem::MpiScope::any(!d.empty())) {
    scene::Diagnostic diag;
    diag.file = scene.source_file;
    diag.key = "continuum";
    diag.message = fmt::format(
        "cannot resume: {} is a checkpoint of another run (first difference: {}). A resume "
        "continues the same computation: run this scene without --resume, or into another --out",
        path.string(), d.empty() ? "on another MPI rank" : d);
    throw scene::SceneError({diag});
  }
  if (!fem::MpiScope::same(from->step))
    return fmt::format("cannot resume: the MPI ranks' checkpoints are of different steps ({} holds "
                       "step {}); run the scene again without --resume",
                       path.string(), from->step);
  return {};
}

} // namespace

RunSummary run(const scene::Scene& scene_in, const RunOptions& options) {
  const scene::Scene scene = seated(scene_in);
  RunSummary summary;
  const auto t_start = std::chrono::steady_clock::now();
  Setup su;
  if (!build_problem(scene, options, su, summary.message)) return summary;
  fem::ensure_mpi();
  const bool root = fem::MpiScope::rank() == 0;
  summary.root = root;
  // an explicit step above the stable step: refused at continuum.dt, as `demfem check` does
  // (scene::set_continuum_step_limit), before the K0 procedure
  if (scene.continuum.integrator == "explicit" && scene.continuum.dt > 0.0)
    if (const auto lim = step_limit(su, scene); scene.continuum.dt > lim.dt)
      throw scene::SceneError({scene::continuum_step_diagnostic(scene, lim)});
  const std::filesystem::path dir = options.out_dir / output::dir::continuum;
  std::error_code ec;
  if (root) std::filesystem::create_directories(dir, ec);
  if (fem::MpiScope::any(static_cast<bool>(ec))) {
    summary.message = fmt::format("cannot create the directory {}: {}", dir.string(),
                                  ec ? ec.message() : "failed on the root rank");
    return summary;
  }
  const bool explicit_dyn = scene.continuum.integrator == "explicit";
  const std::string identity = run_detail::run_identity(scene, su.pb, fem::MpiScope::size());
  std::optional<run_detail::Checkpoint> from;
  if (options.resume) {
    if (auto why = resume_point(scene, explicit_dyn, dir, identity, from, summary); !why.empty()) {
      summary.message = why;
      return summary;
    }
  }
  try {
    Driver d(scene, su.pb, dir, root, identity, from ? &*from : nullptr);
    if (auto why = d.start(summary, t_start); !why.empty()) {
      summary.message = why;
      return summary;
    }
    summary.steps = d.first_step - 1;
    for (long long step = d.first_step; step <= d.nsteps; ++step) {
      if (!d.advance(step, summary)) return summary;
      const double t = d.m.time();
      d.sample(t, step == d.nsteps);
      d.snapshots.at(t, d.dt, step == d.nsteps);
      run_detail::report_progress(options, step, d.nsteps, t, scene.info.duration, t_start);
      summary.steps = step;
      if (d.beyond_validity(t, summary)) break;
      // a stop signal (on any rank: every rank stops after the same step)
      const bool stop =
          step < d.nsteps && fem::MpiScope::any(options.interrupt && options.interrupt->load());
      if (explicit_dyn) d.checkpoint(step, stop);
      if (stop) {
        d.flush();
        summary.interrupted = true;
        summary.simulated_time = t;
        summary.message =
            explicit_dyn
                ? fmt::format("interrupted at t = {:.6g} s (step {} of {}); checkpoint {}; "
                              "continue with --resume",
                              t, step, d.nsteps, run_detail::checkpoint_path(dir, 0).string())
                : fmt::format("stopped at t = {:.6g} s (step {} of {}); the implicit integrator "
                              "writes no checkpoint: the run starts again from t = 0",
                              t, step, d.nsteps);
        summary.wall_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
        return summary;
      }
    }
    std::vector<fem::Point> top; // the soil's top, 101 points across the domain
    for (int i = 0; i < 101; ++i) {
      const double x = su.xmin + (su.xmax - su.xmin) * i / 100;
      top.push_back({x, top_of(su.domain, x, su.zmax) - 1e-9 * (su.zmax - su.zmin)});
    }
    d.finish(summary, top);
  } catch (const std::exception& e) {
    summary.ok = false;
    summary.message = std::string("continuum solver failed: ") + e.what();
  }
  summary.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return summary;
}

} // namespace demfem::continuum
