// Scene-driven continuum run: maps a Scene onto fem::Problem, initialises gravity, integrates the
// scene's duration with Newmark-β and writes probes, a surface profile and .vtu/.pvd snapshots.
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

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <set>

#include "constitutive/k0.hpp"
#include "constitutive/registry.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/validate.hpp"
#include "demfem/scene/write_file.hpp"
#include "fem.hpp"
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

// A streamed output (a time series, the log) whose every write is checked (issue 13): the first
// failure (a full disk, a file size limit, an unwritable directory) is kept as "cannot write
// <path>: <cause>" and later writes are dropped. Nothing is thrown here: the run reports it at
// its next collective point (see raise_write_errors), so that every MPI rank stops together.
class CheckedStream {
public:
  void open(const std::filesystem::path& p) {
    path_ = p;
    errno = 0;
    f_.open(p, std::ios::trunc);
    check("creating");
  }
  [[nodiscard]] bool is_open() const { return f_.is_open(); }
  template <class T> CheckedStream& operator<<(const T& v) {
    if (f_.is_open() && error_.empty()) {
      f_ << v;
      check("writing");
    }
    return *this;
  }
  CheckedStream& operator<<(std::ostream& (*manip)(std::ostream&)) {
    if (f_.is_open() && error_.empty()) {
      manip(f_);
      check("writing");
    }
    return *this;
  }
  void flush() { *this << std::flush; }
  void close() {
    if (!f_.is_open()) return;
    flush();
    f_.close();
    check("closing");
  }
  [[nodiscard]] const std::string& error() const { return error_; }

private:
  void check(const char* step) {
    if (f_ || !error_.empty()) return;
    const int err = errno;
    error_ = fmt::format("cannot write {}: {} ({})", path_.string(),
                         err != 0 ? std::strerror(err) : "the stream failed", step);
  }
  std::filesystem::path path_;
  std::ofstream f_;
  std::string error_;
};

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

// A model's parameter block filled from the scene's [soil.continuum] keys.
void read_block(constitutive::Elastic::Parameters& b, const scene::ContinuumSoil& s) {
  b.young = s.young;
  b.poisson = s.poisson;
  b.modulus_exponent = s.modulus_exponent;
  b.modulus_reference_stress = s.modulus_reference_stress;
  b.modulus_min_stress = s.modulus_min_stress;
}
void read_block(constitutive::MohrCoulomb::Parameters& b, const scene::ContinuumSoil& s) {
  read_block(static_cast<constitutive::Elastic::Parameters&>(b), s);
  b.friction_angle = s.friction_angle;
  b.cohesion = s.cohesion;
  b.dilation_angle = s.dilation_angle;
  b.tension_cutoff = s.tension_cutoff;
  b.dilation_cutoff = s.dilation_cutoff;
}
// The scene has no hypoplastic keys yet (its model list names elastic and mohr-coulomb only):
// the block keeps its defaults.
void read_block(constitutive::Hypoplastic::Parameters&, const scene::ContinuumSoil&) {}

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
  // the soil's model, chosen by its keyword (constitutive/registry.hpp)
  constitutive::Parameters block =
      constitutive::Material::parameters(scene::keyword(scene::kContinuumModelNames, soil.model));
  std::visit([&](auto& b) { read_block(b, soil); }, block);
  pb.soil = constitutive::Material(block);
  pb.density = soil.density;
  if (pb.soil.stiffness_from_stress()) {
    // E = young (p/p_ref)^n (scene.hpp, constitutive/elastic.hpp), capped at the deepest
    // geostatic in-plane mean stress ρ g H (1 + K0)/2 (the explicit step is bounded with it)
    const double k0 = constitutive::k0_at_rest(soil.k0, soil.friction_angle);
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

RunSummary run(const scene::Scene& scene_in, const RunOptions& options) {
  const scene::Scene scene = seated(scene_in);
  RunSummary summary;
  const auto t_start = std::chrono::steady_clock::now();
  Setup su;
  if (!build_problem(scene, options, su, summary.message)) return summary;
  fem::ensure_mpi();
  const bool root = fem::MpiScope::rank() == 0;
  summary.root = root;
  const scene::ContinuumSoil& soil = *scene.soil.continuum;
  const scene::ContinuumOptions& co = scene.continuum;
  const fem::Problem& pb = su.pb;
  const scene::Polygon& domain = su.domain;
  const double xmin = su.xmin, xmax = su.xmax, zmin = su.zmin, zmax = su.zmax;
  const bool explicit_dyn = co.integrator == "explicit";
  // an explicit step above the stable step: refused at continuum.dt, as `demfem check` does
  // (scene::set_continuum_step_limit), before the K0 procedure
  if (explicit_dyn && co.dt > 0.0)
    if (const auto lim = step_limit(su, scene); co.dt > lim.dt)
      throw scene::SceneError({scene::continuum_step_diagnostic(scene, lim)});

  const std::filesystem::path dir = options.out_dir / "continuum";
  std::error_code ec;
  if (root) std::filesystem::create_directories(dir, ec);
  if (fem::MpiScope::any(static_cast<bool>(ec))) {
    summary.message = fmt::format("cannot create the directory {}: {}", dir.string(),
                                  ec ? ec.message() : "failed on the root rank");
    return summary;
  }

  try {
    fem::Model m(pb);
    summary.dofs = m.n_dofs();
    summary.cells = m.n_cells();
    summary.refinement = pb.mesh.refinement;
    summary.degree = pb.degree;
    summary.integrator = pb.integrator;
    {
      const double scale = std::ldexp(1.0, -std::max(0, pb.mesh.refinement));
      summary.h_min = 1e300;
      for (const auto* d : {&pb.mesh.dx, &pb.mesh.dz})
        for (const double v : *d) {
          summary.h_min = std::min(summary.h_min, v * scale);
          summary.h_max = std::max(summary.h_max, v * scale);
        }
    }
    CheckedStream log;
    if (root) {
      log.open(dir / "log.txt");
      const double scale = std::ldexp(1.0, -std::max(0, pb.mesh.refinement));
      const auto [dx0, dx1] = std::minmax_element(pb.mesh.dx.begin(), pb.mesh.dx.end());
      const auto [dz0, dz1] = std::minmax_element(pb.mesh.dz.begin(), pb.mesh.dz.end());
      log << fmt::format("continuum run of {}: {} cells, {} dofs, degree {}, refinement {}, "
                         "cells {:.3g}–{:.3g} m wide, {:.3g}–{:.3g} m tall{}, linear solver {}\n",
                         scene.label(), m.n_cells(), m.n_dofs(), pb.degree, pb.mesh.refinement,
                         *dx0 * scale, *dx1 * scale, *dz0 * scale, *dz1 * scale,
                         co.mesh_size_near > 0.0
                             ? fmt::format(" (graded: {} m coarse at the structures, ratio {})",
                                           co.mesh_size_near, co.mesh_grading)
                             : std::string(),
                         pb.linear_solver)
          << std::flush; // kept if the run is killed
      if (co.absorbing)
        log << "absorbing: Lysmer dashpots on the left, right and bottom boundaries (components "
               "not constrained there: the vertical on the roller sides, none on the fixed base)\n";
    }
    const double k0 = constitutive::k0_at_rest(soil.k0, soil.friction_angle);
    const fem::StepStats g = m.initialise_gravity(true, k0, co.load_steps);
    if (!g.converged) {
      summary.message = "gravity initialisation did not converge\n" + m.log();
      return summary;
    }
    summary.setup_newton_iterations = g.newton_iterations;
    summary.setup_residual = g.residual;
    for (const fem::Seating& st : m.seating())
      summary.seated.emplace_back(pb.regions[st.region].name, st.settlement);
    for (const fem::Seating& st : m.seating())
      if (root)
        log << fmt::format("seated structure '{}' (continuum.seat_structures): it settled {:.4g} m "
                           "under its weight with dof_z free and is held there from t = 0; soil "
                           "reaction {:.4g} N = {:.4f} W (W = {:.4g} N)\n",
                           pb.regions[st.region].name, st.settlement, st.soil_fz,
                           st.soil_fz / st.weight, st.weight);
    if (root)
      log << fmt::format(
                 "setup and K0 initialisation: {:.2f} s wall ({} Newton, {} linear "
                 "iterations)\n",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count(),
                 g.newton_iterations, g.linear_iterations)
          << std::flush;

    // ---- time loop
    const double duration = scene.info.duration;
    // explicit: the loop's step is the probe interval, taken in central-difference substeps of
    // at most the stable step (continuum.dt, when given, must not exceed it)
    double dt = co.dt > 0.0 && !explicit_dyn
                    ? co.dt
                    : std::min(scene.output.probe_interval, duration / 100.0);
    if (explicit_dyn) {
      const double stable = m.stable_time_step(); // co.dt ≤ stable: checked above
      const double h = co.dt > 0.0 ? co.dt : stable;
      summary.dt = h;
      if (root)
        log << fmt::format("explicit central differences: step {:.4g} s ({}), stable step {:.4g} "
                           "s, lumped mass, local damping {}, Rayleigh α = {}, β = {}\n",
                           h, co.dt > 0.0 ? "continuum.dt" : "automatic", stable, co.local_damping,
                           co.rayleigh_alpha, co.rayleigh_beta)
            << std::flush;
    }
    dt = std::max(dt, 1e-9);
    const long long nsteps = std::max<long long>(1, std::llround(std::ceil(duration / dt - 1e-9)));
    dt = duration / double(nsteps);
    if (!explicit_dyn) summary.dt = dt;

    // ---- probes, with the DEM run's names, signs and units (dem/src/run.cpp):
    // structures.csv: <s>.settlement [m] (−z displacement of the pivot), <s>.rotation [rad]
    // (counter-clockwise), <s>.moment [N·m] (soil about the pivot), <s>.force_x/_z [N] (force of
    // the soil on the structure), <s>.applied_moment [N·m] (external loads about the pivot),
    // <s>.displacement_x [m]; continuum only: <s>.applied_force_x/_z [N] (the load histories).
    // walls.csv: <w>.thrust [N] = F·n with n the normal of the chord from the first to the last
    // outline vertex pointing out of the soil (scene::thrust_normal, as the DEM): > 0 when the soil
    // presses on the wall, < 0 in tension; <w>.reaction_x/_z [N] = F (soil force on the wall).
    // pressure_<w>.csv: <w>.binK [Pa], normal soil pressure on the structure per z bin between
    // the outline's lowest and highest vertex.
    std::vector<std::size_t> thrust;                   // structure indices
    std::vector<std::pair<std::size_t, int>> pressure; // structure index, bins
    auto index_of = [&](const std::string& name) -> long {
      for (std::size_t k = 0; k < scene.structures.size(); ++k)
        if (scene.structures[k].name == name) return static_cast<long>(k);
      return -1;
    };
    auto add_thrust = [&](long k) {
      if (k >= 0 && std::find(thrust.begin(), thrust.end(), std::size_t(k)) == thrust.end())
        thrust.push_back(std::size_t(k));
    };
    for (std::size_t k = 0; k < scene.structures.size(); ++k) {
      const auto& s = scene.structures[k];
      if (s.kind == scene::StructureKind::Wall ||
          std::find(s.record.begin(), s.record.end(), "thrust") != s.record.end())
        add_thrust(long(k));
    }
    for (const auto& pr : scene.probes) {
      if (pr.kind == scene::ProbeKind::WallThrust) add_thrust(index_of(pr.target));
      if (pr.kind == scene::ProbeKind::PressureProfile && index_of(pr.target) >= 0)
        pressure.emplace_back(std::size_t(index_of(pr.target)), pr.bins);
    }
    auto zrange = [&](std::size_t k) {
      double lo = 1e300, hi = -1e300;
      for (const auto& p : scene.structures[k].outline) {
        lo = std::min(lo, p.z);
        hi = std::max(hi, p.z);
      }
      return std::pair{lo, hi};
    };
    CheckedStream sfile, wfile;
    std::vector<CheckedStream> pfiles(pressure.size());
    CheckedStream stepfile; // solver statistics per step (benchmarks: bench/RESULTS.md)
    // Collective: the first failed write of any output ends the run on every rank, naming the
    // file and the cause (and it goes to log.txt when that is still writable).
    auto raise_write_errors = [&] {
      std::string failure;
      for (const CheckedStream* f : {&sfile, &wfile, &stepfile, &log})
        if (failure.empty()) failure = f->error();
      for (const auto& f : pfiles)
        if (failure.empty()) failure = f.error();
      if (!fem::MpiScope::any(!failure.empty())) return;
      if (root) log << "run failed: " << failure << "\n" << std::flush;
      throw scene::WriteError(failure.empty() ? "an output could not be written on the root rank"
                                              : failure);
    };
    if (root) {
      if (!scene.structures.empty()) {
        sfile.open(dir / "structures.csv");
        sfile << "time [s]";
        for (const auto& s : scene.structures)
          for (const char* q : {"settlement [m]", "rotation [rad]", "moment [N·m]", "force_x [N]",
                                "force_z [N]", "applied_moment [N·m]", "displacement_x [m]",
                                "applied_force_x [N]", "applied_force_z [N]"})
            sfile << "," << s.name << "." << q;
        sfile << "\n";
      }
      if (!thrust.empty()) {
        wfile.open(dir / "walls.csv");
        wfile << "time [s]";
        for (auto k : thrust)
          for (const char* q : {"thrust [N]", "reaction_x [N]", "reaction_z [N]"})
            wfile << "," << scene.structures[k].name << "." << q;
        wfile << "\n";
      }
      for (std::size_t j = 0; j < pressure.size(); ++j) {
        const auto& name = scene.structures[pressure[j].first].name;
        pfiles[j].open(dir / ("pressure_" + name + ".csv"));
        pfiles[j] << "time [s]";
        for (int b = 0; b < pressure[j].second; ++b)
          pfiles[j] << fmt::format(",{}.bin{} [Pa]", name, b);
        pfiles[j] << "\n";
      }
    }
    auto flush_all = [&] {
      sfile.flush();
      wfile.flush();
      for (auto& f : pfiles) f.flush();
    };
    auto write_probes = [&](double t) {
      std::vector<fem::Model::RegionMotion> motion;
      std::vector<fem::Reaction> react;
      for (std::size_t k = 0; k < scene.structures.size(); ++k) {
        motion.push_back(m.region_motion(k));
        react.push_back(m.soil_reaction(k));
      }
      std::vector<std::vector<double>> prof;
      for (const auto& [k, bins] : pressure) {
        const auto [lo, hi] = zrange(k);
        prof.push_back(m.soil_pressure(k, lo, hi, bins));
      }
      if (!root) return raise_write_errors();
      if (sfile.is_open()) {
        sfile << fmt::format("{:.6g}", t);
        for (std::size_t k = 0; k < scene.structures.size(); ++k) {
          const auto& s = scene.structures[k];
          const double fx = s.force_x(t), fz = s.force_z(t);
          // applied moment about the pivot: M + (load point − pivot) × F
          const double ma =
              s.moment(t) + (s.load_point.x - s.pivot.x) * fz - (s.load_point.z - s.pivot.z) * fx;
          sfile << fmt::format(",{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}",
                               -motion[k].uz, motion[k].rotation, react[k].moment, react[k].fx,
                               react[k].fz, ma, motion[k].ux, fx, fz);
        }
        sfile << "\n";
      }
      if (wfile.is_open()) {
        wfile << fmt::format("{:.6g}", t);
        for (auto k : thrust) {
          const auto n = scene::thrust_normal(scene.structures[k].outline, scene.domain);
          wfile << fmt::format(",{:.9g},{:.9g},{:.9g}", react[k].fx * n.x + react[k].fz * n.z,
                               react[k].fx, react[k].fz);
        }
        wfile << "\n";
      }
      for (std::size_t j = 0; j < pressure.size(); ++j) {
        pfiles[j] << fmt::format("{:.6g}", t);
        for (double v : prof[j]) pfiles[j] << fmt::format(",{:.9g}", v);
        pfiles[j] << "\n";
      }
      raise_write_errors();
    };
    int snapshot = 0;
    const bool vtk = scene.output.vtk;
    if (vtk) m.write_vtu(dir.string(), "continuum", snapshot++);
    write_probes(0.0);
    double next_probe = scene.output.probe_interval, next_out = scene.output.interval;
    long long newton_total = 0, linear_total = 0, cuts_total = 0, substeps_total = 0;
    const auto t_dyn = std::chrono::steady_clock::now();
    if (root) {
      stepfile.open(dir / "steps.csv");
      stepfile << "step,time [s],newton iterations,linear iterations,step cuts,converged,"
                  "relative residual,wall [s],explicit substeps\n";
    }
    for (long long step = 1; step <= nsteps; ++step) {
      const auto t_step = std::chrono::steady_clock::now();
      const fem::StepStats st = m.dynamic_step(dt);
      if (root)
        stepfile
            << fmt::format(
                   "{},{:.6g},{},{},{},{},{:.3e},{:.4f},{}\n", step, m.time(), st.newton_iterations,
                   st.linear_iterations, st.cuts, st.converged ? 1 : 0, st.residual,
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - t_step).count(),
                   st.substeps)
            << std::flush;
      newton_total += st.newton_iterations;
      linear_total += st.linear_iterations;
      cuts_total += st.cuts;
      substeps_total += st.substeps;
      if (root && (st.cuts > 0 || st.newton_iterations > 10))
        log << fmt::format("step {} (t = {:.4g} s): {} Newton iterations, {} cuts\n", step,
                           m.time(), st.newton_iterations, st.cuts)
            << std::flush;
      if (!st.converged) {
        summary.message =
            fmt::format("{} at t = {:.6g} s\n{}",
                        explicit_dyn ? "explicit integration diverged" : "Newton did not converge",
                        m.time(), m.log());
        summary.steps = step;
        summary.simulated_time = m.time();
        return summary;
      }
      const double t = m.time();
      if (t >= next_probe - 1e-9 * dt || step == nsteps) {
        write_probes(t);
        if (root && step % 50 == 0) flush_all();
        next_probe += scene.output.probe_interval;
      }
      if (vtk && (t >= next_out - 1e-9 * dt || step == nsteps)) {
        m.write_vtu(dir.string(), "continuum", snapshot++);
        next_out += scene.output.interval;
      }
      if (options.progress && (step % 10 == 0 || step == nsteps)) {
        scene::Progress p;
        p.stage = "continuum";
        p.time = t;
        p.end_time = duration;
        p.step = step;
        p.wall_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
        options.progress(p);
      }
      summary.steps = step;
      if (co.max_displacement > 0.0) { // small-strain validity limit
        std::string over;
        for (std::size_t k = 0; k < scene.structures.size() && over.empty(); ++k) {
          const auto mo = m.region_motion(k);
          const double moved = std::hypot(mo.ux, mo.uz);
          if (moved > co.max_displacement)
            over = fmt::format("{} moved {:.4g} m", scene.structures[k].name, moved);
        }
        if (!over.empty()) {
          if (t < next_probe - 1e-9 * dt && step != nsteps) write_probes(t);
          if (vtk && t < next_out - 1e-9 * dt) m.write_vtu(dir.string(), "continuum", snapshot++);
          summary.note = fmt::format(
              "stopped at t = {:.4g} s of {:.4g} s: {} > continuum.max_displacement = {:.4g} m "
              "(beyond the small-strain model's validity)",
              t, duration, over, co.max_displacement);
          if (root) log << summary.note << "\n";
          break;
        }
      }
    }
    if (vtk) m.write_pvd(dir.string(), "continuum");
    raise_write_errors(); // a failed steps.csv row or log line since the last probe row

    // ---- surface settlement profile at the end
    std::vector<std::pair<double, double>> profile;
    const int n = 101;
    for (int i = 0; i < n; ++i) {
      const double x = xmin + (xmax - xmin) * i / (n - 1);
      const double z = top_of(domain, x, zmax) - 1e-9 * (zmax - zmin);
      profile.emplace_back(x, -m.displacement({x, z}).z);
    }
    std::string failure;
    if (root) {
      std::string csv = "x [m],settlement [m]\n";
      for (const auto& [x, s] : profile) csv += fmt::format("{:.6g},{:.9g}\n", x, s);
      try {
        scene::write_file_atomic(dir / "surface_profile.csv", csv);
      } catch (const scene::WriteError& e) {
        failure = e.what();
        log << "run failed: " << failure << "\n" << std::flush;
      }
    }
    if (fem::MpiScope::any(!failure.empty()))
      throw scene::WriteError(failure.empty() ? "surface_profile.csv: failed on the root rank"
                                              : failure);
    // Coulomb contact planes (continuum.interface = "coulomb"): state at the end (collective
    // before the explicit run has started)
    std::vector<fem::ContactForce> contact_end;
    for (std::size_t k = 0; k < pb.contacts.size(); ++k) contact_end.push_back(m.contact_force(k));
    if (root) {
      log << m.log();
      for (std::size_t k = 0; k < pb.contacts.size(); ++k) {
        const fem::ContactForce& c = contact_end[k];
        const fem::ContactPlane& p = pb.contacts[k];
        log << fmt::format("contact '{}' ({:.4g}, {:.4g})–({:.4g}, {:.4g}), μ_s = {}, μ_d = {}: {} "
                           "nodes in contact ({} sliding), {} separated, soil force ({:.6g}, "
                           "{:.6g}) N, largest slip {:.4g} m, frictional work {:.6g} J\n",
                           p.name, p.a.x, p.a.z, p.b.x, p.b.z, p.mu_static, p.mu_dynamic, c.nodes,
                           c.sliding, c.open, c.fx, c.fz, c.max_slip, c.dissipated);
      }
      log << m.contact_body_summary();
      const double wall_dyn =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_dyn).count();
      log << fmt::format("dynamic: {} steps of {:.6g} s, {} Newton iterations, {} linear "
                         "iterations, {} step cuts, {:.3f} s wall per step ({:.1f} s)\n",
                         summary.steps, dt, newton_total, linear_total, cuts_total,
                         wall_dyn / double(std::max(1LL, summary.steps)), wall_dyn);
      if (explicit_dyn) {
        log << fmt::format("explicit: {} central-difference steps, {:.3g} s wall per simulated "
                           "second\n",
                           substeps_total, wall_dyn / std::max(1e-300, m.time()));
        // where a step's time goes (rank 0; continuum/README.md "MPI")
        const auto pr = m.explicit_profile();
        const double us = 1e6 / double(std::max(1L, pr.steps));
        log << fmt::format(
            "explicit on {} rank(s), rank 0: {} cells with stresses; per step {:.1f} µs = cells "
            "{:.1f} + reduction {:.1f} + replicated nodal update {:.1f} µs; steps {:.1f} s of "
            "{:.1f} s dynamic wall\n",
            pr.ranks, pr.cells, (pr.cells_s + pr.reduce_s + pr.nodal_s) * us, pr.cells_s * us,
            pr.reduce_s * us, pr.nodal_s * us, pr.cells_s + pr.reduce_s + pr.nodal_s, wall_dyn);
      }
    }
    for (CheckedStream* f : {&sfile, &wfile, &stepfile, &log}) f->close();
    for (auto& f : pfiles) f.close();
    raise_write_errors();
    summary.ok = true;
    summary.simulated_time = m.time();
    summary.substeps = substeps_total;
    summary.message = fmt::format("{} steps, {} dofs", summary.steps, m.n_dofs());
  } catch (const std::exception& e) {
    summary.ok = false;
    summary.message = std::string("continuum solver failed: ") + e.what();
  }
  summary.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return summary;
}

} // namespace demfem::continuum
