// Implicit procedures: Newton, static load stepping, Newmark-β, the K0 procedure.
#include "impl.hpp"

namespace demfem::continuum::fem {

void Implicit::size() {
  DynamicSparsityPattern dsp(core.relevant);
  DoFTools::make_sparsity_pattern(core.dof, dsp, core.hom, false);
  SparsityTools::distribute_sparsity_pattern(dsp, core.owned, core.comm, core.relevant);
  K.reinit(core.owned, core.owned, dsp, core.comm);
  M.reinit(core.owned, core.owned, dsp, core.comm);
  K0.reinit(core.owned, core.owned, dsp, core.comm);
  for (Vec* w : {&rhs, &res, &f_internal, &du, &u_n, &v_n, &a_n}) w->reinit(core.owned, core.comm);
}

void Implicit::newmark_va(Vec& vel, Vec& accel) const {
  const double b = core.pb.newmark_beta, g = core.pb.newmark_gamma;
  accel = core.u;
  accel -= u_n;
  accel *= 1.0 / (b * dt_ * dt_);
  accel.add(-1.0 / (b * dt_), v_n);
  accel.add(-(1.0 / (2 * b) - 1.0), a_n);
  vel = v_n;
  vel.add(dt_ * (1 - g), a_n);
  vel.add(dt_ * g, accel);
}

// Newmark's recurrence a₁ = a₀(u₁ − u₀) − a₂ v₀ − a₃ a₀ applied to a prescribed displacement is the
// trapezoidal rule run backwards: its alternating error is never damped (|R(∞)| = 1) and grows
// with every step's truncation error (u = A(t − sin ωt/ω), ω Δt = 0.03: 2× the true amplitude
// after 200 steps). The prescribed motion is known, so its rates are taken from it: v = g′(t),
// a = (g′(t + Δt/2) − g′(t − Δt/2))/Δt (an acceleration averaged over one step, so a kink of g,
// e.g. a ramp's start, is one step's impulse rather than a spike), g′ by central differences with
// h = 1e-4 Δt; the slaves of a rigid body follow their masters' rates through the same relations.
void Implicit::prescribed_rates(Vec& vel, Vec& accel) {
  if (core.lines.empty() || !(dt_ > 0.0)) return;
  if (!(rate_t == core.t && rate_dt == dt_)) {
    const double t0 = core.t, h = 1e-4 * dt_;
    const auto rate = [&](const std::function<double()>& g, double at) {
      core.t = at + h;
      const double gp = g();
      core.t = at - h;
      const double gm = g();
      return (gp - gm) / (2.0 * h);
    };
    rate_v.clear();
    rate_a.clear();
    rate_v.reinit(core.relevant);
    rate_a.reinit(core.relevant);
    for (types::global_dof_index i : core.relevant) {
      if (!core.hom.is_constrained(i)) continue;
      rate_v.add_line(i);
      rate_a.add_line(i);
      const auto it = core.lines.find(i);
      if (it == core.lines.end()) { // box/periodic: homogeneous, as in hom
        if (const auto* entries = core.hom.get_constraint_entries(i))
          for (const auto& e : *entries) {
            rate_v.add_entry(i, e.first, e.second);
            rate_a.add_entry(i, e.first, e.second);
          }
        continue;
      }
      for (const auto& e : it->second.entries) { // raw line: chains resolved by close()
        rate_v.add_entry(i, e.first, e.second);
        rate_a.add_entry(i, e.first, e.second);
      }
      if (it->second.target) {
        rate_v.set_inhomogeneity(i, rate(it->second.target, t0));
        rate_a.set_inhomogeneity(
            i, (rate(it->second.target, t0 + 0.5 * dt_) - rate(it->second.target, t0 - 0.5 * dt_)) /
                   dt_);
      }
    }
    core.t = t0;
    rate_v.close();
    rate_a.close();
    rate_t = core.t;
    rate_dt = dt_;
  }
  rate_v.distribute(vel);
  rate_a.distribute(accel);
}

// Newmark's inertia and Rayleigh damping, M (a + α v) + β K0 v, added to the residual cell by cell
// on the full local vectors: the constrained dofs' acceleration and velocity (a structure moved by
// its motion_x/z/rotation, the nodes tied to it) reach the free soil through the consistent mass
// and β K0 coupling, folded onto the masters by `hom` like the internal force. Multiplying the
// matrices condensed with the homogeneous constraints instead dropped that coupling, Cᵀ M a_g
// (issue 10). `res` then holds f_int + M a + C v − f_ext at every dof, so Model::reaction includes
// the inertia. The tangent keeps the condensed a₀ M + a₁ (α M + β K0): the prescribed motion does
// not depend on the free dofs.
void Implicit::add_dynamic(bool matrix) {
  const Problem& pb = core.pb;
  Vec vel(core.owned, core.comm), accel(core.owned, core.comm), tmp(core.owned, core.comm);
  newmark_va(vel, accel);
  prescribed_rates(vel, accel);
  tmp = accel;
  tmp.add(pb.rayleigh_alpha, vel);
  Vec xg(core.owned, core.relevant, core.comm), vg(core.owned, core.relevant, core.comm);
  xg = tmp; // a + α v
  vg = vel;
  const bool beta = pb.rayleigh_beta != 0.0;
  FEValues<2> fv(core.mapping, core.fe, core.quad,
                 update_values | update_gradients | update_quadrature_points | update_JxW_values);
  const unsigned n = core.fe.n_dofs_per_cell();
  std::vector<types::global_dof_index> ld(n);
  dealii::Vector<double> xe(n), ve(n), fe_(n), crhs(n);
  std::vector<constitutive::Voigt> epsv;
  CellB cb;
  for (const auto& cell : core.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    fv.reinit(cell);
    cell->get_dof_values(xg, xe);
    const auto id = cell->material_id();
    const double r = core.rho[id];
    fe_ = 0;
    for (unsigned q = 0; q < core.nq(); ++q) {
      double xq[2] = {0.0, 0.0}; // (a + α v) at the point
      for (unsigned j = 0; j < n; ++j)
        xq[core.fe.system_to_component_index(j).first] += fv.shape_value(j, q) * xe(j);
      const double w = r * fv.JxW(q);
      // consistent mass: (M x)_i = ∫ ρ N_i x_{c(i)} dA
      for (unsigned i = 0; i < n; ++i)
        fe_(i) += fv.shape_value(i, q) * xq[core.fe.system_to_component_index(i).first] * w;
    }
    if (beta) { // β K0 v = β ∫ Bᵀ D ε(v) dA (B-bar rows, elastic D)
      cell->get_dof_values(vg, ve);
      core.cell_b(fv, cb);
      core.cell_strain(cb, ve, epsv);
      const auto D = core.models[id].elastic_tangent();
      for (unsigned q = 0; q < core.nq(); ++q) {
        double sig[3] = {0, 0, 0};
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) sig[a] += D[a][b] * epsv[q][b];
        const double w = pb.rayleigh_beta * fv.JxW(q);
        for (unsigned i = 0; i < n; ++i) {
          const auto& Bi = cb(i, q);
          fe_(i) += (Bi[0] * sig[0] + Bi[1] * sig[1] + Bi[2] * sig[2]) * w;
        }
      }
    }
    cell->get_dof_indices(ld);
    res.add(ld, fe_);
    for (unsigned i = 0; i < n; ++i) crhs(i) = -fe_(i);
    core.hom.distribute_local_to_global(crhs, ld, rhs);
  }
  res.compress(VectorOperation::add);
  rhs.compress(VectorOperation::add);
  if (has_cabs) { // Lysmer dashpots: on unconstrained boundary components only (condensed)
    Vec cv(core.owned, core.comm);
    Cabs.vmult(cv, vel);
    res += cv;
    core.hom.set_zero(cv);
    rhs -= cv;
  }
  if (matrix) {
    const double b = pb.newmark_beta, g = pb.newmark_gamma;
    const double a0 = 1.0 / (b * dt_ * dt_), a1 = g / (b * dt_);
    K.add(a0 + a1 * pb.rayleigh_alpha, M);
    K.add(a1 * pb.rayleigh_beta, K0);
    if (has_cabs) K.add(a1, Cabs);
  }
}

int Implicit::solve_linear(bool symmetric) {
  // Krylov solves to 1e-8 of the Newton residual: enough for Newton to reach its tolerance
  // (an inexact Newton step, Eisenstat & Walker 1996), far cheaper than 1e-12
  SolverControl control(2000, std::max(1e-300, 1e-8 * rhs.l2_norm()));
  const std::string& s = core.pb.linear_solver;
  du = 0;
  if (s == "direct") {
    PETScWrappers::SparseDirectMUMPS solver(control, core.comm);
    solver.solve(K, du, rhs);
    return 1;
  }
  PETScWrappers::PreconditionBoomerAMG::AdditionalData data;
  data.symmetric_operator = symmetric && s == "cg-amg";
  data.strong_threshold = 0.5;
  PETScWrappers::PreconditionBoomerAMG amg(K, data);
  if (s == "cg-amg" && symmetric) {
    PETScWrappers::SolverCG solver(control, core.comm);
    solver.solve(K, du, rhs, amg);
  } else {
    // restart 100: the yielding backfill's non-symmetric tangent stalls GMRES(30)
    PETScWrappers::SolverGMRES solver(control, core.comm,
                                      PETScWrappers::SolverGMRES::AdditionalData(100));
    solver.solve(K, du, rhs, amg);
  }
  return static_cast<int>(control.last_step());
}

bool Implicit::symmetric_tangent() const {
  // the soil's and, when there is one, the frictional interface layer's (interface_friction < 0:
  // tied, no layer)
  return core.models[0].symmetric_tangent() &&
         (core.pb.interface_friction < 0.0 || core.iface_model.symmetric_tangent());
}

double Implicit::free_norm(const Vec& r) const {
  Vec tmp(r);
  core.hom.set_zero(tmp);
  return tmp.l2_norm();
}

StepStats Implicit::newton(bool dynamic) {
  const Problem& pb = core.pb;
  StepStats st;
  // predictor: prescribed patch values through inhomogeneous constraints
  inh.clear();
  inh.reinit(core.relevant);
  core.update_ghost();
  for (types::global_dof_index i : core.relevant) {
    if (!core.hom.is_constrained(i)) continue;
    inh.add_line(i);
    auto it = core.lines.find(i);
    if (it == core.lines.end()) { // box/periodic: homogeneous, already resolved in hom
      const auto* entries = core.hom.get_constraint_entries(i);
      if (entries)
        for (const auto& e : *entries) inh.add_entry(i, e.first, e.second);
      continue;
    }
    // raw line (chains resolved by close()): du_i = Σ c du_j + target − (u_i − Σ c u_j)
    double g = it->second.target ? it->second.target() : 0.0;
    g -= core.u_ghost(i);
    for (const auto& e : it->second.entries) {
      inh.add_entry(i, e.first, e.second);
      g += e.second * core.u_ghost(e.first);
    }
    if (it->second.target) inh.set_inhomogeneity(i, g);
  }
  inh.close();
  const bool sym = symmetric_tangent();
  double ref = 0.0;
  int nondescent = 0;
  std::ostringstream trace;
  for (int it = 0; it <= pb.newton_max_iterations; ++it) {
    const AffineConstraints<double>& cons = it == 0 ? inh : core.hom;
    predictor_tangent = it == 0;
    assemble(true, cons, dynamic);
    predictor_tangent = false;
    if (dynamic) add_dynamic(true);
    // residual of the condensed system (periodic constraints fold rows): −rhs on free dofs
    const double rn = it == 0 ? free_norm(res) : rhs.l2_norm();
    ref = std::max({ref, f_internal.l2_norm(), res.l2_norm()});
    st.residual = ref > 0 ? rn / ref : rn;
    trace << "  it " << it << " |R|/ref=" << st.residual << return_counts();
    if (it > 0 && (rn <= pb.newton_tolerance * ref || rn < 1e-300)) {
      st.converged = true;
      st.newton_iterations = it;
      if (pb.newton_trace)
        core.log << "newton t=" << core.t << " λ=" << core.lambda << "\n" << trace.str() << "\n";
      return st;
    }
    if (it == pb.newton_max_iterations) break;
    try {
      st.linear_iterations += solve_linear(sym);
    } catch (const std::exception& e) { // e.g. the Krylov solver did not converge: cut the step
      core.log << "linear solver failed: " << std::string(e.what()).substr(0, 160) << "\n";
      break;
    }
    cons.distribute(du);
    if (!std::isfinite(du.l2_norm())) break;
    if (pb.tangent_check && it > 0) { // directional derivative of R along du vs K du = −R
      const Vec u0(core.u), r0(rhs);
      double rel[3];
      int k = 0;
      auto rhs_at = [&](double s) { // rhs at u0 + s du
        core.u = u0;
        core.u.add(s, du);
        assemble(false, core.hom, dynamic);
        if (dynamic) add_dynamic(false);
        return Vec(rhs);
      };
      for (double h : {1e-3, 1e-5, 1e-7}) {
        Vec rp = rhs_at(h);
        const Vec rm = rhs_at(-h);
        // rhs = −R and K du = −R: a consistent K gives (rhs(u + h du) − rhs(u − h du))/(2h) =
        // −dR[du] = −K du = R = −r0
        rp -= rm;
        rp *= 1.0 / (2 * h);
        rp += r0;
        rel[k++] = rp.l2_norm() / r0.l2_norm();
      }
      core.log << "tangent check t=" << core.t << " λ=" << core.lambda << " it=" << it
               << ": |dR[du] + R|/|R| = " << rel[0] << " " << rel[1] << " " << rel[2]
               << " (h = 1e-3, 1e-5, 1e-7 of the Newton step)\n";
      core.u = u0;
      assemble(true, core.hom, dynamic);
      if (dynamic) add_dynamic(true);
    }
    // backtracking line search on the free residual norm
    const Vec u0(core.u);
    double alpha = 1.0, best = 0.0, best_alpha = 1.0;
    for (int ls = 0; ls < 4; ++ls) {
      core.u = u0;
      core.u.add(alpha, du);
      if (it == 0) break; // the predictor carries the prescribed jump: take it whole
      assemble(false, core.hom, dynamic);
      if (dynamic) add_dynamic(false);
      const double rl = rhs.l2_norm();
      if (ls == 0 || rl < best) {
        best = rl;
        best_alpha = alpha;
      }
      if (rl < rn) break;
      alpha *= 0.5;
    }
    if (it > 0 && best >= rn && rn > 1e-3 * pb.newton_tolerance * ref) {
      // no descent along the Newton direction. Non-smooth returns (points flipping between
      // the apex and the cone) can stall Newton just above the tolerance: accept a stalled
      // state below the stagnation tolerance (logged), else give up and let the caller cut.
      core.u = u0;
      if (rn <= stagnation_tolerance * ref) {
        assemble(false, core.hom, dynamic);
        if (dynamic) add_dynamic(false);
        core.log << "accepted stalled Newton at |R|/ref=" << rn / ref << "\n";
        st.converged = true;
        st.newton_iterations = it;
        return st;
      }
      // non-monotone escape: take the full Newton step anyway (a kink of the return map, not a
      // wrong direction, usually blocks descent); give up after `max_nondescent` such steps
      if (++nondescent > max_nondescent) break;
      core.u.add(1.0, du);
      trace << " α=1 (no descent)\n";
      continue;
    }
    if (it > 0 && alpha != best_alpha) {
      core.u = u0;
      core.u.add(best_alpha, du);
    }
    trace << " α=" << best_alpha << "\n";
  }
  core.log << "newton failed: λ=" << core.lambda << " g=" << core.gfactor
           << " structures' weight=" << core.sfactor << " t=" << core.t
           << " residual=" << st.residual << "\n"
           << trace.str();
  st.converged = false;
  st.newton_iterations = pb.newton_max_iterations;
  return st;
}

StepStats Implicit::halves(const StepStats& a, StepStats b) {
  b.cuts += a.cuts + 1;
  b.newton_iterations += a.newton_iterations;
  b.linear_iterations += a.linear_iterations;
  return b;
}

StepStats Implicit::static_to(double lam, double gf, int depth, double sf) {
  const Vec u_save(core.u);
  const double lam0 = core.lambda, gf0 = core.gfactor, sf0 = core.sfactor;
  core.lambda = lam;
  core.gfactor = gf;
  core.sfactor = sf;
  StepStats st = newton(false);
  if (st.converged) {
    core.commit();
    core.log << "static step λ=" << lam << " g=" << gf << " newton=" << st.newton_iterations
             << " linear=" << st.linear_iterations << " residual=" << st.residual << "\n";
    return st;
  }
  core.u = u_save;
  core.lambda = lam0;
  core.gfactor = gf0;
  core.sfactor = sf0;
  core.trial = core.committed;
  if (depth >= 8) return st;
  core.log << "step cut at λ=" << lam << "\n";
  StepStats a = static_to(0.5 * (lam0 + lam), 0.5 * (gf0 + gf), depth + 1, 0.5 * (sf0 + sf));
  if (!a.converged) return a;
  return halves(a, static_to(lam, gf, depth + 1, sf));
}

StepStats Implicit::dynamic_to(double dt, int depth) {
  const Vec u0(core.u), v0(core.v), a0(a_n);
  const double t0 = core.t;
  dt_ = dt;
  u_n = core.u;
  v_n = core.v;
  core.lambda = 1.0;
  core.t += dt;
  // predictor u = u_n + dt v_n + dt²(½ − β) a_n (Newmark 1959)
  core.u.add(dt, v_n);
  core.u.add(dt * dt * (0.5 - core.pb.newmark_beta), a_n);
  StepStats st = newton(true);
  if (st.converged) {
    newmark_va(core.v, core.acc);
    prescribed_rates(core.v, core.acc);
    a_n = core.acc;
    core.commit();
    return st;
  }
  core.u = u0;
  core.v = v0;
  a_n = a0;
  core.t = t0;
  core.trial = core.committed;
  if (depth >= 5) return st;
  core.log << "dynamic step cut at t=" << t0 << " dt=" << dt << "\n";
  StepStats a = dynamic_to(0.5 * dt, depth + 1);
  if (!a.converged) return a;
  return halves(a, dynamic_to(0.5 * dt, depth + 1));
}

void Implicit::start_dynamics(double dt) {
  // initial acceleration: M a0 = fext − f_internal(u0), condensed with the constraints (assemble
  // leaves −R condensed in rhs: a rigid body's rows carry the resultant over all its dofs; the
  // raw residual with the constrained rows zeroed kept only its master nodes' share, a spurious
  // initial acceleration of bodies the soil holds in equilibrium, e.g. a seated foundation)
  assemble(false, core.hom, false);
  v_n = core.v;
  K = 0;
  K.add(1.0, M);
  solve_linear(true);
  core.hom.distribute(du);
  a_n = du;
  dt_ = dt; // the prescribed motion's rates at t (prescribed_rates)
  prescribed_rates(core.v, a_n);
  v_n = core.v;
  core.dyn_init = true;
}

StepStats Model::initialise_gravity(bool use_k0, double k0, int steps) {
  Impl& m = *impl_;
  StepStats total;
  if (use_k0) {
    // K0 procedure: σzz = −ρ g (z_top − z), σxx = σyy = K0 σzz (Jaky 1944 when K0 = 1 − sin φ)
    FEValues<2> fv(m.mapping, m.fe, m.quad, update_quadrature_points);
    for (const auto& cell : m.dof.active_cell_iterators()) {
      if (!cell->is_locally_owned()) continue;
      fv.reinit(cell);
      const auto id = cell->material_id();
      for (unsigned q = 0; q < m.nq(); ++q) {
        const auto x = fv.quadrature_point(q);
        const bool rigid_cell = id > 0 && m.pb.regions[id - 1].rigid; // stresses play no role
        const double szz =
            rigid_cell ? 0.0 : -m.pb.density * m.pb.gravity * std::max(0.0, m.top_at(x[0]) - x[1]);
        QpState& s = m.committed[cell->active_cell_index() * m.nq() + q];
        s.stress = constitutive::Voigt{{k0 * szz, szz, 0.0}};
        s.syy = k0 * szz;
        m.model_of(cell->active_cell_index(), id).set_stress(s);
      }
    }
    m.set_stiffness_from_stress(); // the stress-dependent modulus at the K0 stresses
    m.trial = m.committed;
    // the soil's weight balances the K0 stresses (up to the correction); the structures are
    // weightless here and their weight acts from the first dynamic step on, as in the DEM scenes,
    // where a structure is held while the bed is deposited and released at t = 0 (so settlements
    // include the settlement under the structure's own weight)
    m.gfactor = 1.0;
    m.sfactor = 0.0;
    total = m.im.static_to(m.lambda, 1.0, 0, 0.0);
    // Seating (Region::seat): a structure held vertically but embedded in the soil starts resting
    // on it, as the DEM packing seats it (lowered until the bed carries its weight): its vertical
    // DoF is freed, its weight applied statically with the soil's own model, and the DoF fixed
    // again where it settled; the other structures stay weightless until t = 0. A structure in
    // Coulomb contact (no dofs of its own) is seated through the soil nodes on its faces: they
    // follow one master node vertically, stuck to the body (seat_master), which carries its weight.
    m.seated.clear();
    std::vector<std::size_t> seat;
    for (std::size_t r = 0; r < m.pb.regions.size(); ++r) {
      const Region& reg = m.pb.regions[r];
      if (reg.seat && reg.rigid && reg.dead_weight && reg.mode[1] == Region::Mode::Fixed)
        seat.push_back(r);
    }
    if (total.converged && !seat.empty()) {
      m.seating_mask.assign(m.pb.regions.size(), 0);
      m.seating_contact.assign(m.pb.regions.size(), 0);
      std::vector<double> uz0;
      for (const std::size_t r : seat) {
        m.seating_mask[r] = 1;
        if (m.pb.regions[r].contact)
          m.seating_contact[r] = 1;
        else
          m.pb.regions[r].mode[1] = Region::Mode::Free;
        uz0.push_back(region_motion(r).uz);
      }
      m.reconstrain();
      const StepStats st = m.im.static_to(m.lambda, 1.0, 0, 1.0);
      total.newton_iterations += st.newton_iterations;
      total.linear_iterations += st.linear_iterations;
      total.cuts += st.cuts;
      total.converged = st.converged;
      total.residual = st.residual;
      for (std::size_t k = 0; k < seat.size(); ++k) {
        const std::size_t r = seat[k];
        Seating s;
        s.region = r;
        // a contact body's settlement: its master's (every node on its faces moved with it)
        s.settlement =
            m.pb.regions[r].contact
                ? -Utilities::MPI::max(
                      m.owned.is_element(m.seat_master[r]) ? m.u(m.seat_master[r]) : -1e300, m.comm)
                : -(region_motion(r).uz - uz0[k]);
        s.weight = m.rho[r + 1] * m.geom[r + 1].area * m.pb.gravity; // W = ρ A g per metre
        s.converged = st.converged;
        if (!m.pb.regions[r].contact) s.soil_fz = soil_reaction(r).fz;
        m.pb.regions[r].mode[1] = Region::Mode::Fixed;
        m.seated.push_back(s);
      }
      const bool contact_seated = std::find(m.seating_contact.begin(), m.seating_contact.end(),
                                            1) != m.seating_contact.end();
      m.seating_mask.clear();
      m.seating_contact.clear();
      const Vec u_seated(m.u);
      m.reconstrain();
      // a contact body's soil force: the reactions of the constraints that now hold its face
      // nodes where they settled (contact_state), from a residual without its weight on them
      // (reconstrain put the held dofs back at 0: the seated displacements are restored first)
      if (contact_seated) {
        m.u = u_seated;
        m.im.assemble(false, m.hom, false);
      }
      for (Seating& s : m.seated) {
        if (m.pb.regions[s.region].contact) s.soil_fz = soil_reaction(s.region).fz;
        m.log << "seated region '" << m.pb.regions[s.region].name << "': settlement "
              << s.settlement << " m, soil reaction " << s.soil_fz
              << " N/m = " << s.soil_fz / s.weight << " W (W = " << s.weight << " N/m), "
              << st.newton_iterations << " Newton its, " << st.cuts << " cuts"
              << (st.converged ? "" : ", NOT CONVERGED") << "\n";
      }
    }
    m.sfactor = 1.0;
  } else {
    steps = std::max(1, steps);
    for (int k = 1; k <= steps; ++k) {
      StepStats st = m.im.static_to(m.lambda, double(k) / steps);
      total.newton_iterations += st.newton_iterations;
      total.linear_iterations += st.linear_iterations;
      total.converged = st.converged;
      if (!st.converged) break;
    }
  }
  // displacements restart from zero; stresses stay
  m.u = 0;
  for (auto& s : m.committed) s.eps = constitutive::Voigt{{0, 0, 0}};
  // the stress-dependent modulus at the stresses the dynamics start from (a seated structure's
  // weight included)
  m.set_stiffness_from_stress();
  m.trial = m.committed;
  return total;
}

void Core::set_stiffness_from_stress() {
  if (!models[0].stiffness_from_stress()) return;
  stiffness_set = true;
  for (const auto& cell : dof.active_cell_iterators()) {
    if (!cell->is_locally_owned() || cell->material_id() != 0) continue; // the soil only
    const std::size_t base = cell->active_cell_index() * nq();
    const constitutive::Material& model = model_of(cell->active_cell_index(), 0);
    for (unsigned q = 0; q < nq(); ++q) model.set_stiffness_from_stress(committed[base + q]);
  }
}

const std::vector<Seating>& Model::seating() const {
  return impl_->seated;
}

StepStats Model::static_step(double lambda) {
  return impl_->im.static_to(lambda, impl_->gfactor);
}

void Model::set_displacement(const std::function<Point(Point)>& f) {
  Impl& m = *impl_;
  const auto& usp = m.fe.get_unit_support_points();
  std::vector<types::global_dof_index> ld(m.fe.n_dofs_per_cell());
  for (const auto& cell : m.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    cell->get_dof_indices(ld);
    for (unsigned i = 0; i < ld.size(); ++i) {
      if (!m.owned.is_element(ld[i])) continue;
      const auto p = m.mapping.transform_unit_to_real_cell(cell, usp[i]);
      const Point d = f(Point{p[0], p[1]});
      m.u(ld[i]) = m.fe.system_to_component_index(i).first == 0 ? d.x : d.z;
    }
  }
  m.u.compress(VectorOperation::insert);
  m.hom.distribute(m.u);
  m.dyn_init = false;
  // make the committed strains consistent with u
  m.im.assemble(false, m.hom, false);
  m.commit();
}

StepStats Model::dynamic_step(double dt) {
  Impl& m = *impl_;
  if (m.is_explicit()) return m.ex.advance(dt);
  if (!m.pb.contacts.empty())
    throw std::runtime_error("Coulomb contact planes (continuum.interface = \"coulomb\") need the "
                             "explicit integrator (continuum.integrator = \"explicit\")");
  if (!m.dyn_init) m.im.start_dynamics(dt);
  return m.im.dynamic_to(dt, 0);
}

} // namespace demfem::continuum::fem
