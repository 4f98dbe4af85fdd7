// The implicit integrator of the plane-strain solver: static load stepping and Newmark-β
// dynamics, both solved by Newton's method on the assembled global system (residual, consistent
// tangent, consistent mass, elastic stiffness for Rayleigh damping, Lysmer dashpots). Every run
// uses it for its initial state (the K0 procedure, seating); it owns the global matrices and
// vectors and the Newmark state, and reaches the mesh, constraints, loads, point states and nodal
// fields through the model's Core (core.hpp). Internal header (deal.II's flags, C++17).
#pragma once

#include "core.hpp"

namespace demfem::continuum::fem {

class Implicit {
public:
  explicit Implicit(Core& model) : core(model) {}

  // the global matrices and vectors sized to the dofs and constraints (after build_constraints)
  void size();
  // Consistent mass matrix and initial elastic stiffness (for Rayleigh damping), the dashpots.
  void assemble_mass_and_elastic();
  // Residual (f_internal − fext, raw) and, if `matrix`, the tangent; the linear system (K, rhs =
  // −R) goes through `cons`. Trial states are updated.
  void assemble(bool matrix, const AffineConstraints<double>& cons, bool dynamic);
  // Quadrature points per constitutive::Return region in the last assembly, as " el=… main=…".
  [[nodiscard]] std::string return_counts() const;

  // Newton iteration to equilibrium at (lambda, gfactor) [and time t when dynamic].
  StepStats newton(bool dynamic);
  // static load stepping with step cutting
  StepStats static_to(double lam, double gf, int depth = 0, double sf = 1.0);
  // The initial acceleration of the dynamics at rest or after a set displacement (M a0 = f_ext −
  // f_int(u0)) and the prescribed motion's rates, before the first Newmark step of dt.
  void start_dynamics(double dt);
  // One Newmark step of dt; on a Newton failure the step is undone and taken as two halves
  // (at most 5 levels deep).
  StepStats dynamic_to(double dt, int depth);

  // f_int − f_ext (+ inertia and damping in a dynamic step) at every dof after the last
  // assembly: the reactions at held dofs
  Vec res;
  Mat M, K0; // consistent mass, elastic stiffness (with the constraints `hom`)

private:
  Core& core;
  using CellB = Core::CellB;
  using ContactNode = Core::ContactNode;
  using RegionGeom = Core::RegionGeom;

  // Newmark constants (Newmark 1959): a = a0(u − u_n) − a2 v_n − a3 a_n, v = v_n + dt((1−γ)a_n +
  // γa)
  void newmark_va(Vec& vel, Vec& accel) const;
  // The constrained dofs' velocity and acceleration from their targets' time derivatives (the
  // prescribed motion) and the constraint relations; the free dofs' are left as they are.
  void prescribed_rates(Vec& vel, Vec& accel);
  // Add the inertia and Rayleigh damping forces M(a + αv) + βK0 v (C = αM + βK0, Rayleigh), cell by
  // cell on the full vectors (the prescribed dofs' coupling included), and the dashpots.
  void add_dynamic(bool matrix);
  int solve_linear(bool symmetric);
  bool symmetric_tangent() const;
  double free_norm(const Vec& r) const;
  // statistics of a step taken as two halves a, b (b's convergence and residual)
  static StepStats halves(const StepStats& a, StepStats b);

  static constexpr double stagnation_tolerance = 1e-5;
  static constexpr int max_nondescent = 3;

  Mat K, Cabs; // Newton's tangent; the Lysmer dashpots
  bool has_cabs = false;
  Vec rhs, f_internal, du, u_n, v_n, a_n;
  AffineConstraints<double> inh; // the Newton predictor's: `hom` with the prescribed jumps
  // prescribed_rates: the constraints giving the constrained dofs' velocity and acceleration at
  // time rate_t (rebuilt when the time changes)
  AffineConstraints<double> rate_v, rate_a;
  double rate_t = std::numeric_limits<double>::quiet_NaN(), rate_dt = 0.0;
  double dt_ = 0.0;               // the Newmark step
  bool predictor_tangent = false; // first Newton iteration: yielding points keep a plastic tangent
  std::array<long, constitutive::kReturnNames.size()> returns{}; // by region, last assembly
};

} // namespace demfem::continuum::fem
