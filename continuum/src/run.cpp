// Scene-driven continuum run: maps a Scene onto fem::Problem, initialises gravity, integrates the
// scene's duration with Newmark-β and writes probes, a surface profile and .vtu/.pvd snapshots.
//
// Modelling choices (see continuum/README.md):
// - mesh: tensor-product grid through every vertex coordinate of the domain and the structures,
//   coarse size min(width, height)/4, refined `refinement` times; cells whose centre lies outside
//   the domain and all structures are removed (stair-stepped inclined boundaries);
// - structures are very stiff elastic regions (E = 1000 × soil E, ν = 0.2) tied to the soil;
//   their external force/moment histories act as body forces with the same resultant;
// - boundaries: sides on rollers, base fixed.
#include "demfem/continuum/run.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "fem.hpp"

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

} // namespace

RunSummary run(const scene::Scene& scene, const RunOptions& options) {
  RunSummary summary;
  const auto t_start = std::chrono::steady_clock::now();
  if (!scene.soil.continuum) {
    summary.message = "the scene has no [soil.continuum] section";
    return summary;
  }
  if (scene.domain.size() < 3) {
    summary.message = "the scene has no domain polygon";
    return summary;
  }
  fem::ensure_mpi();
  const bool root = fem::MpiScope::rank() == 0;
  const scene::ContinuumSoil& soil = *scene.soil.continuum;
  const scene::ContinuumOptions& co = scene.continuum;

  fem::Problem pb;
  // ---- mesh
  std::set<double> xs, zs;
  double xmin = 1e300, xmax = -1e300, zmin = 1e300, zmax = -1e300;
  auto add = [&](const scene::Vec2& p) {
    xs.insert(p.x);
    zs.insert(p.z);
    xmin = std::min(xmin, p.x);
    xmax = std::max(xmax, p.x);
    zmin = std::min(zmin, p.z);
    zmax = std::max(zmax, p.z);
  };
  for (const auto& p : scene.domain) add(p);
  for (const auto& s : scene.structures)
    for (const auto& p : s.outline) add(p);
  const double h0 = std::min(xmax - xmin, zmax - zmin) / 4.0;
  pb.mesh.x0 = xmin;
  pb.mesh.z0 = zmin;
  pb.mesh.dx = steps_through(xs, h0);
  pb.mesh.dz = steps_through(zs, h0);
  for (const auto& p : scene.domain) pb.mesh.domain.push_back({p.x, p.z});
  pb.mesh.refinement = options.refinement >= 0 ? options.refinement : co.refinement;
  pb.degree = options.degree >= 1 ? options.degree : co.degree;

  // ---- materials
  pb.soil.young = soil.young;
  pb.soil.poisson = soil.poisson;
  pb.soil.plastic = soil.model == scene::ContinuumModel::MohrCoulomb;
  pb.soil.friction = soil.friction_angle;
  pb.soil.cohesion = soil.cohesion;
  pb.soil.dilation = soil.dilation_angle;
  pb.soil.tension_cutoff = soil.tension_cutoff > 0.0 ? soil.tension_cutoff : -1.0;
  pb.density = soil.density;
  for (const auto& s : scene.structures) {
    fem::Region r;
    r.name = s.name;
    for (const auto& p : s.outline) r.outline.push_back({p.x, p.z});
    r.material.young = 1000.0 * soil.young; // "very stiff" elastic body
    r.material.poisson = 0.2;
    r.material.plastic = false;
    const double area = std::abs(scene::signed_area(s.outline));
    r.density = s.mass > 0.0 && area > 0.0 ? s.mass / area : s.density;
    r.force_x = s.force_x;
    r.force_z = s.force_z;
    r.moment = s.moment;
    r.load_point = {s.load_point.x, s.load_point.z};
    r.pivot = {s.pivot.x, s.pivot.z};
    pb.regions.push_back(r);
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

  const std::filesystem::path dir = options.out_dir / "continuum";
  std::error_code ec;
  if (root) std::filesystem::create_directories(dir, ec);

  try {
    fem::Model m(pb);
    summary.dofs = m.n_dofs();
    std::ofstream log;
    if (root) {
      log.open(dir / "log.txt");
      log << fmt::format("continuum run of {}: {} cells, {} dofs, degree {}, refinement {}\n",
                         scene.label(), m.n_cells(), m.n_dofs(), pb.degree, pb.mesh.refinement);
      if (co.absorbing) log << "note: absorbing (Lysmer) boundaries are not implemented yet\n";
    }
    const double k0 = soil.k0 >= 0.0 ? soil.k0 : 1.0 - std::sin(soil.friction_angle); // Jaky (1944)
    const fem::StepStats g = m.initialise_gravity(true, k0, co.load_steps);
    if (!g.converged) {
      summary.message = "gravity initialisation did not converge\n" + m.log();
      return summary;
    }

    // ---- time loop
    const double duration = scene.info.duration;
    double dt = co.dt > 0.0 ? co.dt : std::min(scene.output.probe_interval, duration / 100.0);
    dt = std::max(dt, 1e-9);
    const long long nsteps = std::max<long long>(1, std::llround(std::ceil(duration / dt - 1e-9)));
    dt = duration / double(nsteps);

    std::ofstream probes;
    if (root) {
      probes.open(dir / "probes.csv");
      probes << "time [s]";
      for (const auto& s : scene.structures)
        probes << "," << s.name << ".settlement [m]," << s.name << ".rotation [rad],"
               << s.name << ".force_x [N]," << s.name << ".force_z [N]," << s.name
               << ".moment [N·m]";
      probes << "\n";
    }
    auto write_probes = [&](double t) {
      std::vector<fem::Model::RegionMotion> motion;
      for (std::size_t k = 0; k < scene.structures.size(); ++k) motion.push_back(m.region_motion(k));
      if (!root) return;
      probes << fmt::format("{:.6g}", t);
      for (std::size_t k = 0; k < scene.structures.size(); ++k) {
        const auto& s = scene.structures[k];
        probes << fmt::format(",{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}", -motion[k].uz,
                              motion[k].rotation, s.force_x(t), s.force_z(t), s.moment(t));
      }
      probes << "\n";
    };
    int snapshot = 0;
    const bool vtk = scene.output.vtk;
    if (vtk) m.write_vtu(dir.string(), "continuum", snapshot++);
    write_probes(0.0);
    double next_probe = scene.output.probe_interval, next_out = scene.output.interval;
    long long newton_total = 0;
    for (long long step = 1; step <= nsteps; ++step) {
      const fem::StepStats st = m.dynamic_step(dt);
      newton_total += st.newton_iterations;
      if (!st.converged) {
        summary.message = fmt::format("Newton did not converge at t = {:.6g} s\n{}", m.time(), m.log());
        summary.steps = step;
        summary.simulated_time = m.time();
        return summary;
      }
      const double t = m.time();
      if (t >= next_probe - 1e-9 * dt || step == nsteps) {
        write_probes(t);
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
    }
    if (vtk) m.write_pvd(dir.string(), "continuum");

    // ---- surface settlement profile at the end
    std::vector<std::pair<double, double>> profile;
    const int n = 101;
    for (int i = 0; i < n; ++i) {
      const double x = xmin + (xmax - xmin) * i / (n - 1);
      const double z = top_of(scene.domain, x, zmax) - 1e-9 * (zmax - zmin);
      profile.emplace_back(x, -m.displacement({x, z}).z);
    }
    if (root) {
      std::ofstream f(dir / "surface_profile.csv");
      f << "x [m],settlement [m]\n";
      for (const auto& [x, s] : profile) f << fmt::format("{:.6g},{:.9g}\n", x, s);
      log << m.log();
      log << fmt::format("dynamic: {} steps of {:.6g} s, {} Newton iterations\n", nsteps, dt,
                         newton_total);
    }
    summary.ok = true;
    summary.simulated_time = m.time();
    summary.message = fmt::format("{} steps, {} dofs", nsteps, m.n_dofs());
  } catch (const std::exception& e) {
    summary.ok = false;
    summary.message = std::string("continuum solver failed: ") + e.what();
  }
  summary.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return summary;
}

} // namespace demfem::continuum
