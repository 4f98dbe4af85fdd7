#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "constitutive/soil.hpp"
#include "hooks.hpp"

namespace demfem::continuum::run_detail {

void describe(RunSummary& summary, const fem::Model& m, const fem::Problem& pb) {
  summary.dofs = m.n_dofs();
  summary.cells = m.n_cells();
  summary.refinement = pb.mesh.refinement;
  summary.degree = pb.degree;
  summary.integrator = pb.integrator;
  const double scale = std::ldexp(1.0, -std::max(0, pb.mesh.refinement));
  summary.h_min = 1e300;
  for (const auto* d : {&pb.mesh.dx, &pb.mesh.dz})
    for (const double v : *d) {
      summary.h_min = std::min(summary.h_min, v * scale);
      summary.h_max = std::max(summary.h_max, v * scale);
    }
}

void log_header(CheckedStream& log, const scene::Scene& scene, const fem::Model& m,
                const fem::Problem& pb) {
  const scene::ContinuumOptions& co = scene.continuum;
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

std::string initialise(fem::Model& m, const scene::Scene& scene, const fem::Problem& pb,
                       CheckedStream& log, bool root, RunSummary& summary,
                       std::chrono::steady_clock::time_point t_start) {
  const scene::ContinuumSoil& soil = *scene.soil.continuum;
  const double k0 = constitutive::soil_k0(soil);
  const fem::StepStats g = m.initialise_gravity(true, k0, scene.continuum.load_steps);
  if (!g.converged) return "gravity initialisation did not converge\n" + m.log();
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
  return {};
}

double loop_step(fem::Model& m, const scene::Scene& scene, double finest_interval,
                 CheckedStream& log, bool root, RunSummary& summary, long long& nsteps) {
  const scene::ContinuumOptions& co = scene.continuum;
  const bool explicit_dyn = co.integrator == "explicit";
  const double duration = scene.info.duration;
  double dt = co.dt > 0.0 && !explicit_dyn ? co.dt : std::min(finest_interval, duration / 100.0);
  if (explicit_dyn) {
    const double stable = m.stable_time_step(); // co.dt ≤ stable: checked before the K0 stage
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
  nsteps = std::max<long long>(1, std::llround(std::ceil(duration / dt - 1e-9)));
  dt = duration / double(nsteps);
  if (!explicit_dyn) summary.dt = dt;
  return dt;
}

void log_end(CheckedStream& log, const fem::Model& m, const fem::Problem& pb, bool root,
             const RunSummary& summary, const Totals& totals, double dt, bool explicit_dyn,
             std::chrono::steady_clock::time_point t_dyn) {
  // Coulomb contact planes (continuum.interface = "coulomb"): state at the end (collective
  // before the explicit run has started)
  std::vector<fem::ContactForce> contact_end;
  for (std::size_t k = 0; k < pb.contacts.size(); ++k) contact_end.push_back(m.contact_force(k));
  if (!root) return;
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
                     summary.steps, dt, totals.newton, totals.linear, totals.cuts,
                     wall_dyn / double(std::max(1LL, summary.steps)), wall_dyn);
  if (explicit_dyn) {
    log << fmt::format("explicit: {} central-difference steps, {:.3g} s wall per simulated "
                       "second\n",
                       totals.substeps, wall_dyn / std::max(1e-300, m.time()));
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

} // namespace demfem::continuum::run_detail
