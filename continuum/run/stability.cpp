// Continuum rows of `demfem study stability` (issue 11 item 2): small problems with a closed form
// or a bound, each run to completion or to its specific diagnostic.
#include "demfem/continuum/stability.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <numbers>

#include <fmt/format.h>

#include "constitutive/soil.hpp"
#include "demfem/continuum/run.hpp"
#include "demfem/continuum/verification.hpp"
#include "demfem/scene/load.hpp"
#include "fem.hpp"

namespace demfem::continuum {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

constexpr double kB = 2.0;      // footing width [m]
constexpr double kE = 2.0e7;    // soil Young's modulus [Pa]
constexpr double kTheta = 1e-4; // prescribed rotation [rad]
constexpr double kBlock = 0.25; // stiff block thickness [m]

// Elastic half-space (100 m each way, cells of 0.125 m under the footing growing by 1.35) with a
// smooth rigid footing of width B at the surface rotated by θ about its centre.
fem::Problem rocking_problem(double nu, bool bbar, int degree) {
  fem::Problem pb;
  const double L = 100.0;
  const std::vector<double> half = graded(kB, 0.125, L, 1.35);
  pb.mesh.x0 = -L;
  pb.mesh.z0 = -L;
  pb.mesh.dx.assign(half.rbegin(), half.rend());
  pb.mesh.dx.insert(pb.mesh.dx.end(), half.begin(), half.end());
  pb.mesh.dz.assign(half.rbegin(), half.rend());
  pb.degree = degree;
  pb.bbar = bbar;
  pb.soil = constitutive::Material(constitutive::Elastic(constitutive::Hooke{kE, nu}));
  pb.gravity = 0.0;
  pb.linear_solver = "direct";
  fem::Patch footing;
  footing.name = "footing";
  footing.a = {-0.5 * kB, 0.0};
  footing.b = {0.5 * kB, 0.0};
  footing.constrain_x = false; // smooth contact
  footing.rotation = kTheta;
  footing.pivot = {0.0, 0.0};
  pb.patches.push_back(footing);
  return pb;
}

// K_r = M/θ of a rocking problem; fills the case's iterations, residual and size.
double rocking_stiffness(const fem::Problem& pb, StabilityCase& c) {
  fem::Model m(pb);
  c.dofs = m.n_dofs();
  const fem::StepStats st = m.static_step(1.0);
  c.newton_iterations += st.newton_iterations;
  c.load_steps += 1;
  c.residuals.push_back(st.residual);
  if (!st.converged) {
    c.outcome = "stopped";
    c.cause = fmt::format("Newton did not converge (residual {:.3e} after {} iterations, {} step "
                          "cuts)",
                          st.residual, st.newton_iterations, st.cuts);
    return NAN;
  }
  return m.reaction(0).moment / kTheta; // the footing's moment on the soil, +Kθ
}

// Gazetas (1991): rocking stiffness of a rigid strip of width B per metre, πGB²/(8(1 − ν)).
double gazetas(double nu) {
  const double G = kE / (2.0 * (1.0 + nu));
  return std::numbers::pi * G * kB * kB / (8.0 * (1.0 - nu));
}

} // namespace

StabilityCase rocking_locking_case(double nu, bool bbar, int degree) {
  fem::ensure_mpi();
  StabilityCase c;
  c.name = fmt::format("nu-{:g}{}", nu, bbar ? "-bbar" : "-no-bbar");
  c.description = fmt::format("built-in rigid strip footing rocking on elastic soil, ν = {:g}, "
                              "Q{} {} B-bar",
                              nu, degree, bbar ? "with" : "without");
  const auto t0 = Clock::now();
  c.outcome = "completed";
  const double K = rocking_stiffness(rocking_problem(nu, bbar, degree), c);
  c.wall_seconds = since(t0);
  c.value = K;
  c.bound = gazetas(nu);
  if (std::isfinite(K))
    c.measure = fmt::format("rocking stiffness K_r = {:.4e} N·m/rad/m = {:.4f} × πGB²/(8(1 − ν)) "
                            "(Gazetas 1991)",
                            K, K / c.bound);
  return c;
}

StabilityCase stiff_structure_case(double ratio, int degree) {
  fem::ensure_mpi();
  StabilityCase c;
  c.name = fmt::format("stiff-structure-x{:g}", ratio);
  c.description = fmt::format("built-in footing on an elastic block {:g}× stiffer than the soil "
                              "(E = {:.3g} Pa, {:g} m thick, tied), Q{}, ν = 0.3",
                              ratio, ratio * kE, kBlock, degree);
  const auto t0 = Clock::now();
  c.outcome = "completed";
  const fem::Problem soil_only = rocking_problem(0.3, true, degree);
  const auto with_block = [&](double r) {
    fem::Problem pb = soil_only;
    fem::Region block;
    block.name = "block";
    block.outline = {{-0.5 * kB, -kBlock}, {0.5 * kB, -kBlock}, {0.5 * kB, 0.0}, {-0.5 * kB, 0.0}};
    block.material.young = r * kE;
    block.material.poisson = 0.3;
    block.density = 2400.0;
    pb.regions.push_back(block);
    return pb;
  };
  // the bound: the same block 10³× stiffer than the soil, already rigid in effect (its own
  // rocking compliance is 10⁻³ of the soil's): at 10⁶ the stiffness must be the same, or the
  // contrast has spoiled the solve
  StabilityCase ref;
  const double K0 = rocking_stiffness(with_block(1.0e3), ref);
  const fem::Problem pb = with_block(ratio);
  const double K = rocking_stiffness(pb, c);
  // explicit stable steps with and without the block (element bound, Irons 1970): the block's
  // wave speed √(E/ρ) sets the step
  const double dt_soil = fem::stable_time_step(soil_only);
  const double dt_block = fem::stable_time_step(pb);
  c.wall_seconds = since(t0);
  c.value = K;
  c.bound = K0;
  if (std::isfinite(K))
    c.measure = fmt::format(
        "rocking stiffness {:.6e} N·m/rad/m = {:.6f} × the same block 10³× stiffer than the "
        "soil ({:.6e}); explicit stable step {:.3e} s with the block against {:.3e} s without "
        "({:.2e}×): a structure this stiff is modelled rigid",
        K, K / K0, K0, dt_block, dt_soil, dt_block / dt_soil);
  return c;
}

StabilityCase bearing_capacity_case(double factor, int degree) {
  fem::ensure_mpi();
  StabilityCase c;
  c.name = fmt::format("load-{:g}x-prandtl", factor);
  c.description = fmt::format("built-in strip pressure {:g} × (2 + π)c on weightless undrained "
                              "clay (φ = 0), load-controlled, Q{}",
                              factor, degree);
  const double Bf = 1.0, cu = 1.0e4;
  const double limit = (2.0 + std::numbers::pi) * cu; // Prandtl (1920)
  fem::Problem pb;
  pb.degree = degree;
  pb.mesh.x0 = 0.0; // symmetry plane x = 0 (roller)
  pb.mesh.z0 = -5.0 * Bf;
  pb.mesh.dx = graded(1.0 * Bf, 0.125 * Bf, 5.0 * Bf, 1.3);
  pb.mesh.dz = graded(1.0 * Bf, 0.125 * Bf, 5.0 * Bf, 1.3);
  std::reverse(pb.mesh.dz.begin(), pb.mesh.dz.end());
  constitutive::Elastic::Parameters elastic;
  elastic.young = 1.0e7;
  elastic.poisson = 0.3;
  constitutive::MohrCoulomb::Parameters clay; // undrained: φ = ψ = 0, c = c_u
  clay.friction_angle = 0.0;
  clay.dilation_angle = 0.0;
  clay.cohesion = cu;
  pb.soil = constitutive::Material(constitutive::MohrCoulomb(elastic, clay));
  pb.gravity = 0.0;
  pb.linear_solver = "direct";
  pb.newton_max_iterations = 15;
  pb.tractions.push_back({{0.0, 0.0}, {0.5 * Bf, 0.0}, factor * limit});
  const auto t0 = Clock::now();
  fem::Model m(pb);
  c.dofs = m.n_dofs();
  const int steps = 10;
  double reached = 0.0;
  c.outcome = "completed";
  for (int k = 1; k <= steps; ++k) {
    const double lam = static_cast<double>(k) / steps;
    const fem::StepStats st = m.static_step(lam);
    c.newton_iterations += st.newton_iterations;
    c.load_steps += 1;
    c.residuals.push_back(st.residual);
    if (!st.converged) {
      c.outcome = "stopped";
      c.cause = fmt::format(
          "no equilibrium at q = {:.4f} × (2 + π)c (load step {} of {}): Newton did not converge "
          "after 8 step cuts (residual {:.3e}); the last completed load step was q = {:.4f} × (2 + "
          "π)c",
          lam * factor, k, steps, st.residual, reached);
      break;
    }
    reached = lam * factor;
  }
  const double settle = -m.displacement({0.0, 0.0}).z;
  c.wall_seconds = since(t0);
  c.value = reached;
  c.bound = 1.0;
  c.measure = fmt::format("largest pressure in equilibrium {:.4f} × (2 + π)c = {:.4g} Pa (Prandtl "
                          "1920); centre settlement there {:.3e} m",
                          reached, reached * limit, settle);
  return c;
}

StabilityCase scene_locking_case(const scene::Scene& scene, double nu, bool bbar) {
  StabilityCase c;
  c.name = fmt::format("scene-nu-{:g}{}", nu, bbar ? "-bbar" : "-no-bbar");
  c.description = fmt::format("the scene's continuum (its mesh, structures, seating) at ν = {:g}, "
                              "{} B-bar: static stage, then explicit steps",
                              nu, bbar ? "with" : "without");
  const auto t0 = Clock::now();
  if (!scene.soil.continuum) {
    c.outcome = "not applicable";
    c.cause = "the scene has no [soil.continuum]";
    return c;
  }
  scene::Scene s = scene;
  s.continuum.integrator = "explicit";
  s.continuum.dt = 0.0; // automatic: the stable step at this ν
  s.continuum.dt_line = s.continuum.dt_column = 0;
  s.output.vtk = false;
  s.output.figures = false;
  const auto own = stable_step(s);
  constitutive::elastic_block(*s.soil.continuum).poisson = nu;
  s.continuum.bbar = bbar;
  const auto lim = stable_step(s);
  if (!lim) {
    c.outcome = "not applicable";
    c.cause = "the scene's continuum cannot be meshed";
    return c;
  }
  // ten steps at the stable step of this ν: the explicit update runs, bounded in time
  s.info.duration = 10.0 * lim->dt;
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() /
      fmt::format("demfem-stability-nu-{}", Clock::now().time_since_epoch().count());
  try {
    RunOptions o;
    o.out_dir = out;
    const auto r = run(s, o);
    c.outcome = r.ok ? "completed" : "stopped";
    c.cause = r.ok ? "" : r.message;
    c.load_steps = static_cast<int>(r.substeps > 0 ? r.substeps : r.steps);
    c.dofs = r.dofs;
    c.newton_iterations = r.setup_newton_iterations;
    c.residuals = {r.setup_residual}; // the static stage's (the explicit steps have none)
    std::string seated;
    for (const auto& [name, w] : r.seated) {
      seated += fmt::format("{}{} seated {:.4e} m", seated.empty() ? "" : ", ", name, w);
      if (c.value == 0.0) c.value = w;
    }
    c.measure = fmt::format(
        "{}; explicit stable step {:.3e} s{}, {} dofs",
        seated.empty() ? std::string("no seated structure (nothing to lock against at rest)")
                       : seated,
        lim->dt,
        own && own->dt > 0.0
            ? fmt::format(" = {:.3f} × the scene's (ν = {:g})", lim->dt / own->dt,
                          constitutive::elastic_block(*scene.soil.continuum).poisson)
            : std::string(),
        r.dofs);
  } catch (const scene::SceneError& e) {
    c.outcome = "refused";
    c.cause = e.diagnostics().empty() ? e.what() : e.diagnostics().front().format();
  } catch (const std::exception& e) {
    c.outcome = "stopped";
    c.cause = e.what();
  }
  std::error_code ec;
  std::filesystem::remove_all(out, ec);
  c.bound = lim->dt;
  c.wall_seconds = since(t0);
  return c;
}

StabilityCase explicit_step_case(const scene::Scene& scene, double factor) {
  StabilityCase c;
  c.name = fmt::format("explicit-dt-{:g}x", factor);
  c.description = fmt::format("the scene's continuum, explicit, continuum.dt = {:g} × its stable "
                              "step",
                              factor);
  const auto t0 = Clock::now();
  scene::Scene s = scene;
  s.continuum.integrator = "explicit";
  s.continuum.dt = 0.0;
  s.info.duration = std::min(s.info.duration, 1e-3); // bounded if it ever ran
  s.output.vtk = false;
  const auto lim = stable_step(s);
  if (!lim) {
    c.outcome = "not applicable";
    c.cause = "the scene's continuum cannot be meshed";
    return c;
  }
  s.continuum.dt = factor * lim->dt;
  c.bound = lim->dt;
  c.value = s.continuum.dt;
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() /
      fmt::format("demfem-stability-dt-{}",
                  std::chrono::steady_clock::now().time_since_epoch().count());
  try {
    RunOptions o;
    o.out_dir = out;
    const auto r = run(s, o);
    c.outcome = r.ok ? "completed" : "stopped";
    c.cause = r.message;
    c.load_steps = static_cast<int>(r.steps);
    c.dofs = r.dofs;
  } catch (const scene::SceneError& e) {
    c.outcome = "refused";
    c.cause = e.diagnostics().empty() ? e.what() : e.diagnostics().front().format();
  }
  std::error_code ec;
  std::filesystem::remove_all(out, ec);
  c.wall_seconds = since(t0);
  c.measure = fmt::format("continuum.dt = {:.4e} s against the stable step {:.4e} s ({})", c.value,
                          c.bound, lim->formula);
  return c;
}

} // namespace demfem::continuum
