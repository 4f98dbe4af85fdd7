// Explicit central-difference dynamics (velocity-Verlet form of the central-difference method,
// Belytschko, Liu & Moran 2000 §6.2): lumped (row-sum) mass, internal force cell by cell from the
// B̄ rows and the constitutive seam (no global matrix), automatic stable step from an element
// bound on the highest frequency (Irons 1970), the implicit path's loads, constraints, rigid
// bodies and base shaking. On N MPI ranks of the shared triangulation (continuum/README.md
// "MPI"): each rank updates the stresses and sums the internal force of its locally owned cells,
// one MPI_Allreduce per step adds the ranks' parts, and the O(ndof) nodal update, contact and
// rigid bodies run replicated, so every rank holds the same state.
#include "impl.hpp"

namespace demfem::continuum::fem {

namespace {
// solve the k×k system A x = b (k ≤ 3) by Gaussian elimination with partial pivoting
void solve_small(int k, double A[3][3], double b[3]) {
  for (int c = 0; c < k; ++c) {
    int p = c;
    for (int r = c + 1; r < k; ++r)
      if (std::abs(A[r][c]) > std::abs(A[p][c])) p = r;
    for (int j = 0; j < k; ++j) std::swap(A[c][j], A[p][j]);
    std::swap(b[c], b[p]);
    for (int r = c + 1; r < k; ++r) {
      const double f = A[r][c] / A[c][c];
      for (int j = c; j < k; ++j) A[r][j] -= f * A[c][j];
      b[r] -= f * b[c];
    }
  }
  for (int c = k - 1; c >= 0; --c) {
    for (int j = c + 1; j < k; ++j) b[c] -= A[c][j] * b[j];
    b[c] /= A[c][c];
  }
}
// Sum of a replicated per-dof array over the ranks, in place (every rank gets the same sums).
void allreduce_sum(std::vector<double>& x, MPI_Comm comm) {
  if (Utilities::MPI::n_mpi_processes(comm) == 1 || x.empty()) return;
  const int rc =
      MPI_Allreduce(MPI_IN_PLACE, x.data(), static_cast<int>(x.size()), MPI_DOUBLE, MPI_SUM, comm);
  AssertThrowMPI(rc);
}

// the small rigid motion S(x) q of a body at (x, z) about its pivot p:
// S = [[1, 0, −(z − zp)], [0, 1, x − xp]] (as the tied body's rows)
void rigid_at(const double q[3], const Point& p, double x, double z, double out[2]) {
  out[0] = q[0] - q[2] * (z - p.z);
  out[1] = q[1] + q[2] * (x - p.x);
}
} // namespace

void Model::Impl::explicit_setup() {
  Explicit& e = ex;
  const bool several = Utilities::MPI::n_mpi_processes(comm) > 1;
  const std::size_t N = dof.n_dofs();
  const unsigned n = fe.n_dofs_per_cell();
  e.n = n;
  e.nq = nq();
  for (auto* w : {&e.u, &e.v, &e.a, &e.f, &e.f_int, &e.mass, &e.damp, &e.f_static, &e.f_shake})
    w->assign(N, 0.0);
  e.f_region.assign(pb.regions.size(), {});
  for (auto& fr : e.f_region)
    for (auto& w : fr) w.assign(N, 0.0);
  // the current state (the K0 state at rest, or a set displacement): each rank has its owned
  // entries, the others are 0, so the sum over the ranks is exact
  for (const auto i : owned) {
    e.u[i] = u(i);
    e.v[i] = v(i);
  }
  allreduce_sum(e.u, comm);
  allreduce_sum(e.v, comm);

  FEValues<2> fv(mapping, fe, quad,
                 update_values | update_gradients | update_quadrature_points | update_JxW_values);
  FEFaceValues<2> ffv(mapping, fe, face_quad,
                      update_values | update_quadrature_points | update_normal_vectors |
                          update_JxW_values);
  std::vector<types::global_dof_index> ld(n);
  CellB cb;
  const double tol = 1e-7 * std::max(xmax - xmin, zmax - zmin);
  e.cell_dofs.clear();
  e.cell_B.clear();
  e.cell_w.clear();
  e.cell_base.clear();
  e.cell_model.clear();
  e.cell_De.clear();
  for (const auto& cell : dof.active_cell_iterators()) {
    fv.reinit(cell);
    cell->get_dof_indices(ld);
    const auto id = cell->material_id();
    const bool rigid_cell = id > 0 && pb.regions[id - 1].rigid;
    const double r = rho[id];
    for (unsigned q = 0; q < nq(); ++q) {
      const double w = fv.JxW(q);
      const auto xq = fv.quadrature_point(q);
      // body forces: gravity along −z (structures' weight if dead_weight), base shaking ρ·a(t)
      // per unit acceleration (soil only, as in assemble), structure loads per unit
      // resultant/moment (as in assemble)
      const bool weight = id == 0 || pb.regions[id - 1].dead_weight;
      const double gz = weight ? -r * pb.gravity * gfactor * weight_factor(id) : 0.0;
      double unit[3][2] = {{0, 0}, {0, 0}, {0, 0}};
      if (id > 0) {
        const RegionGeom& g = geom[id];
        const Region& reg = pb.regions[id - 1];
        // b = F/A + M_tot/J e_z × (x − x_c), M_tot = M + (load point − centroid) × F
        const double ax = -(reg.load_point.z - g.zc), az = reg.load_point.x - g.xc;
        const double mx = -(xq[1] - g.zc) / g.J, mz = (xq[0] - g.xc) / g.J;
        unit[0][0] = 1.0 / g.area + ax * mx; // unit Fx
        unit[0][1] = ax * mz;
        unit[1][0] = az * mx; // unit Fz
        unit[1][1] = 1.0 / g.area + az * mz;
        unit[2][0] = mx; // unit moment
        unit[2][1] = mz;
      }
      for (unsigned i = 0; i < n; ++i) {
        const unsigned ci = fe.system_to_component_index(i).first;
        const double Nw = fv.shape_value(i, q) * w;
        // row-sum lumping: m_i = Σ_j M_ij = ∫ ρ N_i (Σ_j N_j = 1); positive for Lagrange Q1/Q2
        e.mass[ld[i]] += r * Nw;
        if (ci == 1) e.f_static[ld[i]] += gz * Nw;
        if (pb.shaking_component >= 0 && ci == unsigned(pb.shaking_component) && id == 0)
          e.f_shake[ld[i]] += r * Nw;
        if (id > 0)
          for (int k = 0; k < 3; ++k) e.f_region[id - 1][k][ld[i]] += unit[k][ci] * Nw;
      }
    }
    // strip tractions at the current load factor: t = −p n
    for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f) {
      if (!cell->face(f)->at_boundary()) continue;
      const auto fc = cell->face(f)->center();
      for (const Traction& tr : pb.tractions) {
        if (!on_segment(tr.a, tr.b, fc[0], fc[1], tol)) continue;
        ffv.reinit(cell, f);
        for (unsigned q = 0; q < ffv.n_quadrature_points; ++q)
          for (unsigned i = 0; i < n; ++i) {
            const unsigned ci = fe.system_to_component_index(i).first;
            e.f_static[ld[i]] += ffv.shape_value(i, q) *
                                 (-tr.pressure * lambda * ffv.normal_vector(q)[ci]) * ffv.JxW(q);
          }
      }
      // Lysmer & Kuhlemeyer (1969) dashpots, lumped: c_i = ∫ N_i ρ (c_p n_i² + c_s (1 − n_i²))
      const auto bid = cell->face(f)->boundary_id();
      if (!pb.absorbing || bid > 3 || !pb.absorbing_sides[bid]) continue;
      ffv.reinit(cell, f);
      const constitutive::Hooke& P = models[id].elasticity().hooke;
      const double G = P.shear_modulus(), lam = P.lame();
      const double cp = std::sqrt((lam + 2 * G) / r), cs = std::sqrt(G / r);
      for (unsigned q = 0; q < ffv.n_quadrature_points; ++q) {
        const auto nrm = ffv.normal_vector(q);
        for (unsigned i = 0; i < n; ++i) {
          const unsigned ci = fe.system_to_component_index(i).first;
          const double n2 = nrm[ci] * nrm[ci];
          e.damp[ld[i]] += ffv.shape_value(i, q) * r * (cp * n2 + cs * (1 - n2)) * ffv.JxW(q);
        }
      }
    }
    if (rigid_cell) continue; // a small rigid motion has no strain: no stress, no internal force
    // the masses and loads above come from every cell on every rank (identical sums); stresses
    // and internal forces only from this rank's cells (their states are updated here only)
    if (!cell->is_locally_owned()) continue;
    cell_b(fv, cb);
    e.cell_base.push_back(cell->active_cell_index() * nq());
    e.cell_model.push_back(&model_of(cell->active_cell_index(), id));
    e.cell_De.push_back(models[id].elastic_tangent());
    for (unsigned i = 0; i < n; ++i) e.cell_dofs.push_back(ld[i]);
    for (unsigned q = 0; q < nq(); ++q) {
      e.cell_w.push_back(fv.JxW(q));
      for (unsigned i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) e.cell_B.push_back(cb(i, q)[k]);
    }
  }
  // mass-proportional Rayleigh damping: c_i = α m_i (plus the dashpots)
  for (std::size_t i = 0; i < N; ++i) e.damp[i] += pb.rayleigh_alpha * e.mass[i];

  // dof classes from the constraints
  e.kind.assign(N, 0);
  e.follows.clear();
  e.prescribed.clear();
  e.bodies.clear();
  for (std::size_t r = 0; r < pb.regions.size(); ++r) {
    if (rigid[r].is_dof.empty()) continue;
    Explicit::Body b;
    b.region = r;
    const Region& reg = pb.regions[r];
    for (const auto& [i, cp] : rigid[r].dofs) {
      e.kind[i] = 4;
      b.dofs.push_back(i);
      const double rx = cp.second[0] - reg.pivot.x, rz = cp.second[1] - reg.pivot.z;
      // u = (ux − θ(z − zp), uz + θ(x − xp))
      b.rows.push_back(cp.first == 0 ? std::array<double, 3>{{1.0, 0.0, -rz}}
                                     : std::array<double, 3>{{0.0, 1.0, rx}});
    }
    // generalised mass M_q = Σ_i m_i row_i row_iᵀ
    for (std::size_t k = 0; k < b.dofs.size(); ++k)
      for (int a = 0; a < 3; ++a)
        for (int c = 0; c < 3; ++c) b.M[a][c] += e.mass[b.dofs[k]] * b.rows[k][a] * b.rows[k][c];
    // start from the current displacement of the pivot
    for (int a = 0; a < 3; ++a)
      for (int j = 0; j < 3; ++j) b.q[a] += rigid[r].T[a][j] * e.u[rigid[r].master[j]];
    for (int a = 0; a < 3; ++a) b.q_prev[a] = b.q[a];
    e.bodies.push_back(std::move(b));
  }
  // moving structures in Coulomb contact (Region::contact, a DoF not fixed): unmeshed rigid
  // bodies whose faces are moving contact planes (explicit_contact_body)
  for (std::size_t r = 0; r < pb.regions.size(); ++r) {
    const Region& reg = pb.regions[r];
    if (!reg.contact || (reg.mode[0] == Region::Mode::Fixed && reg.mode[1] == Region::Mode::Fixed &&
                         reg.mode[2] == Region::Mode::Fixed))
      continue;
    Explicit::Body b;
    b.region = r;
    b.contact = true;
    const RegionGeom& g = geom[r + 1];
    if (g.area <= 0.0 || rho[r + 1] <= 0.0)
      throw std::runtime_error("structure '" + reg.name +
                               "' in Coulomb contact has no mass (its "
                               "outline's area × density is 0)");
    const double m = rho[r + 1] * g.area, dx = g.xc - reg.pivot.x, dz = g.zc - reg.pivot.z;
    // M_q = ∫ ρ Sᵀ S dA with S = [[1, 0, −(z − zp)], [0, 1, x − xp]] (small rigid motion about
    // the pivot): m, static moments m (x_c − x_p), m (z_c − z_p) and the polar moment about the
    // pivot ρ (J_c + A |c − p|²) (parallel-axis theorem)
    b.M[0][0] = b.M[1][1] = m;
    b.M[0][2] = b.M[2][0] = -m * dz;
    b.M[1][2] = b.M[2][1] = m * dx;
    b.M[2][2] = rho[r + 1] * (g.J + g.area * (dx * dx + dz * dz));
    // dead weight −m g at the centroid (as the tied body's cells get it): Q = Sᵀ(c) (0, −m g)
    const double W =
        reg.dead_weight ? m * pb.gravity * gfactor * weight_factor(types::material_id(r + 1)) : 0.0;
    b.Qw[1] = -W;
    b.Qw[2] = -W * dx;
    e.bodies.push_back(std::move(b));
  }
  // `hom` knows the locally relevant dofs only: each rank classifies its owned dofs, and the
  // classes are gathered below (one rank: all dofs are owned)
  bool unsupported = false;
  for (std::size_t i = 0; i < N; ++i) {
    if (e.kind[i] == 4 || !owned.is_element(i) || !hom.is_constrained(i)) continue;
    const auto it = lines.find(i);
    if (it != lines.end() && it->second.target) {
      e.kind[i] = 2;
      e.prescribed.emplace_back(i, it->second.target());
      continue;
    }
    const auto* entries = hom.get_constraint_entries(i);
    if (!entries || entries->empty()) {
      e.kind[i] = 1;
      continue;
    }
    if (entries->size() != 1 || e.kind[(*entries)[0].first] != 0 ||
        std::abs((*entries)[0].second - 1.0) > 1e-12) {
      unsupported = true;
      continue;
    }
    e.kind[i] = 3;
    e.follows.emplace_back(i, (*entries)[0].first);
  }
  if (several) explicit_gather_classes();
  for (const auto& [i, j] : e.follows) // (a master classified on another rank)
    unsupported = unsupported || e.kind[j] != 0;
  if (Utilities::MPI::max(unsupported ? 1 : 0, comm) != 0) // refused on every rank together
    throw std::runtime_error("the explicit integrator supports only u_i = u_j constraints "
                             "(periodic sides) besides rigid bodies and fixed dofs");
  // u_i = u_j: condensed mass and damping of the master
  for (const auto& [i, j] : e.follows) {
    e.mass[j] += e.mass[i];
    e.damp[j] += e.damp[i];
  }
  for (const auto& [i, val] : e.prescribed) e.u[i] = val;
  explicit_contact_setup();
  // every rank bounds every cell (the whole shared mesh): the same step; the reduction keeps it so
  e.dt_stable = Utilities::MPI::min(explicit_stable_step(), comm);
  e.omega_max = Utilities::MPI::max(e.omega_max, comm);
  e.ready = true;
  log << "explicit: " << N << " dofs, " << Utilities::MPI::sum(e.cell_base.size(), comm)
      << " cells with stresses";
  if (several)
    log << " (" << e.cell_base.size() << " on rank " << Utilities::MPI::this_mpi_process(comm)
        << " of " << Utilities::MPI::n_mpi_processes(comm) << ")";
  log << ", " << e.bodies.size() << " rigid bodies, " << e.contacts.size()
      << " Coulomb contact nodes, ω_max ≤ " << e.omega_max << " rad/s, Δt = " << e.dt_stable
      << " s (" << pb.explicit_safety << " of the critical step)\n";
}

// Several ranks: every rank classified its owned dofs (fixed, prescribed with their value, periodic
// with their master; `contact_roller`); the sums over the ranks (each dof has one owner, the others
// give 0) give every rank all of them, listed in dof order as on one rank. Rigid-body dofs are
// classified on every rank already.
void Model::Impl::explicit_gather_classes() {
  Explicit& e = ex;
  const std::size_t N = e.kind.size();
  std::vector<double> buf(4 * N, 0.0); // class, prescribed value, master + 1, roller
  for (const auto i : owned)
    if (e.kind[i] != 4) {
      buf[i] = e.kind[i];
      buf[3 * N + i] = contact_roller[i];
    }
  for (const auto& [i, x] : e.prescribed) buf[N + i] = x;
  for (const auto& [i, j] : e.follows) buf[2 * N + i] = double(j) + 1.0;
  allreduce_sum(buf, comm);
  e.prescribed.clear();
  e.follows.clear();
  for (std::size_t i = 0; i < N; ++i) {
    contact_roller[i] = buf[3 * N + i] != 0.0;
    if (e.kind[i] == 4) continue;
    e.kind[i] = static_cast<char>(buf[i]);
    if (e.kind[i] == 2) e.prescribed.emplace_back(i, buf[N + i]);
    if (e.kind[i] == 3)
      e.follows.emplace_back(i, static_cast<types::global_dof_index>(buf[2 * N + i] - 1.0));
  }
}

// A contact record of a node on a plane: its dofs, outward normal and position, no force yet.
Model::Impl::Explicit::Contact Model::Impl::contact_at(const ContactNode& n, std::size_t plane) {
  Explicit::Contact c;
  c.ix = n.ix;
  c.iz = n.iz;
  c.nx = n.nx;
  c.nz = n.nz;
  c.x = n.X[0];
  c.z = n.X[1];
  c.plane = plane;
  return c;
}

// Coulomb contact nodes: every soil node on a contact plane's faces, unless one of its dofs is
// held otherwise (a rigid body, a prescribed or periodic dof, or fixed by a box boundary
// condition of a face off the planes, e.g. the corner with a fixed base): such a node keeps
// those constraints and takes no contact force.
void Model::Impl::explicit_contact_setup() {
  Explicit& e = ex;
  e.contacts.clear();
  e.contact_work.assign(pb.contacts.size(), 0.0);
  const auto nodes = contact_nodes();
  std::vector<int> body_of(pb.regions.size(), -1); // region → its moving contact body
  for (std::size_t bi = 0; bi < e.bodies.size(); ++bi) {
    e.bodies[bi].contacts.clear();
    if (e.bodies[bi].contact) body_of[e.bodies[bi].region] = static_cast<int>(bi);
  }
  std::set<std::pair<int, types::global_dof_index>> on_body; // (body, node): one record each
  for (std::size_t k = 0; k < nodes.size(); ++k)
    for (const ContactNode& c : nodes[k]) {
      bool held = false, rigid_or_linked = false;
      for (const auto i : {c.ix, c.iz}) {
        held = held || (e.kind[i] != 0 && !(e.kind[i] == 1 && contact_roller[i]));
        rigid_or_linked = rigid_or_linked || e.kind[i] >= 2;
      }
      if (rigid_or_linked) continue; // its force belongs to a rigid body, a patch or a master
      Explicit::Contact ct = contact_at(c, k);
      ct.held = held;
      const int region = pb.contacts[k].region;
      if (region >= 0 && body_of[region] >= 0 && !held) {
        // a node at a corner of the body (on two of its faces) keeps the first face's contact
        // only: one normal per node keeps the body's coupled system regular
        if (!on_body.insert({body_of[region], c.ix}).second) continue;
        ct.body = body_of[region];
        e.bodies[ct.body].contacts.push_back(e.contacts.size());
      }
      e.contacts.push_back(ct);
    }
  for (const auto& c : e.contacts)
    if (!c.held) e.kind[c.ix] = e.kind[c.iz] = 0;
}

// Kinematic node-on-plane contact with Coulomb friction for explicit central differences
// (forward-increment Lagrange multipliers, Carpenter, Taylor & Katona 1991; Belytschko, Liu &
// Moran 2000 §10.4): from the trial acceleration a* = f/m of each contact node, the normal force
// N = m (g + Δt v_n + Δt τ a*_n)/(Δt τ) puts the node back on the plane at the next step
// (g = u·n, penetration positive); N ≤ 0 means the node leaves the plane (no force). The stick
// force F = −m (v_t/τ + a*_t) stops its tangential motion at the next velocity; Coulomb: it
// sticks when |F| ≤ μ_s N, otherwise it slides under μ_d N against the trial tangential motion
// (sign F). τ is the time to the next velocity (Δt, or Δt/2 at the initial acceleration).
void Model::Impl::explicit_contacts() {
  Explicit& e = ex;
  const double dt = e.contact_dt, tau = e.contact_tau;
  for (auto& c : e.contacts) {
    if (c.body >= 0 && !c.held) continue; // with its body (explicit_contact_body)
    c.fx = c.fz = c.N = c.Ft = 0.0;
    c.slide = false;
    if (c.held) { // the normal part of the reaction −f that holds the fixed dof at rest
      const types::global_dof_index i = std::abs(c.nx) > 0.5 ? c.ix : c.iz;
      if (e.kind[i] != 1) continue;
      const double r = -e.f[i];
      (i == c.ix ? c.fx : c.fz) = r;
      c.N = std::max(0.0, -(c.fx * c.nx + c.fz * c.nz));
      continue;
    }
    if (dt <= 0 || tau <= 0) continue;
    const double m = e.mass[c.ix];
    const double tx = -c.nz, tz = c.nx;
    const double g = c.nx * e.u[c.ix] + c.nz * e.u[c.iz];
    const double vn = c.nx * e.v[c.ix] + c.nz * e.v[c.iz];
    const double an = c.nx * e.a[c.ix] + c.nz * e.a[c.iz];
    const double N = m * (g + dt * vn + dt * tau * an) / (dt * tau);
    if (N <= 0.0) continue; // separating: the node leaves the plane
    const double vt = tx * e.v[c.ix] + tz * e.v[c.iz];
    const double at = tx * e.a[c.ix] + tz * e.a[c.iz];
    const ContactPlane& p = pb.contacts[c.plane];
    double F = -m * (vt / tau + at); // stick
    if (std::abs(F) > p.mu_static * N) {
      F = (F > 0 ? 1.0 : -1.0) * p.mu_dynamic * N; // Coulomb sliding
      c.slide = true;
    }
    // force of the plane on the soil node: −N n + F t
    c.N = N;
    c.Ft = F;
    c.fx = -N * c.nx + F * tx;
    c.fz = -N * c.nz + F * tz;
    e.a[c.ix] += c.fx / m;
    e.a[c.iz] += c.fz / m;
  }
}

// A moving rigid body in Coulomb contact with the soil (Region::contact with a DoF not fixed):
// the kinematic contact of explicit_contacts against a moving surface, solved with the body's
// equation of motion. Node i (lumped mass m_i, trial acceleration a*_i = f_i/m_i) touches the body
// at its reference point X_i, where the body's surface moves with J_i q (J_i = S(X_i), rigid_at).
// With gap g and normal velocity v_n of the node relative to that surface, the targets of the
// node's relative acceleration are those of explicit_contacts (Carpenter, Taylor & Katona 1991):
//   normal  d_n = −(g + Δt v_n)/(Δt τ)   (back on the surface at the next step)
//   stick   d_t = −v_t/τ                 (no relative tangential velocity at the next velocity)
// Sticking: r_i = m_i (d_i − a*_i + J_i q̈) (the force of the body on the node); sliding:
// r_i = N_i w_i, w_i = −n + s μ_d t, N_i = m_i (n·a*_i − d_n − n·J_i q̈); open: r_i = 0.
// The body M q̈ = Q − Σ J_iᵀ r_i; eliminating r_i gives the 3×3 Schur complement
//   (M + Σ_stick m J_iᵀJ_i − Σ_slide m J_iᵀ w_i n_iᵀ J_i) q̈ = Q − Σ_stick m J_iᵀ(d_i − a*_i)
//                                                              − Σ_slide m J_iᵀ w_i (n·a*_i − d_n)
// over the free DoFs (fixed ones at rest, prescribed ones with their motion's second
// difference). The active set (open / stick / slide and the slip direction) starts from the last
// step's and is updated from the Coulomb cone and the sign of N with the solved q̈, at most 8
// passes; the forces are those of the last solve, so that soil + body momentum is exact whatever
// the set (only the Coulomb law can be violated by an unsettled set: counted in `unsettled`).
namespace {
// A rigid body's generalised DoFs (x, z, rotation): the free ones listed in `fr` (their count
// returned), a prescribed one's acceleration in `ap` by the central difference of its motion
// (q(t+Δt) − 2q(t) + q(t−Δt))/Δt², a fixed one left at rest.
int free_and_prescribed(const Region& reg, double t, double dt, int fr[3], double ap[3]) {
  int nf = 0;
  for (int a = 0; a < 3; ++a) {
    if (reg.mode[a] == Region::Mode::Free)
      fr[nf++] = a;
    else if (reg.mode[a] == Region::Mode::Prescribed && dt > 0)
      ap[a] = (reg.motion[a](t + dt) - 2 * reg.motion[a](t) + reg.motion[a](t - dt)) / (dt * dt);
  }
  return nf;
}
} // namespace

void Model::Impl::explicit_contact_body(Explicit::Body& b, double dt) {
  Explicit& e = ex;
  const Region& reg = pb.regions[b.region];
  const Point p = reg.pivot;
  const double h = e.contact_dt, tau = e.contact_tau;
  // generalised external force: weight, the loads (resultant at load_point and a couple: Q =
  // (Fx, Fz, M + (l − p) × F)) and mass-proportional Rayleigh damping −α M_q q̇ (as on the tied
  // body's dofs)
  const double Fx = lambda * reg.force_x(t), Fz = lambda * reg.force_z(t);
  double Q[3] = {b.Qw[0] + Fx, b.Qw[1] + Fz,
                 b.Qw[2] + lambda * reg.moment(t) + (reg.load_point.x - p.x) * Fz -
                     (reg.load_point.z - p.z) * Fx};
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) Q[a] -= pb.rayleigh_alpha * b.M[a][c] * b.qv[c];
  double ap[3] = {0, 0, 0};
  int fr[3];
  const int nf = free_and_prescribed(reg, t, dt, fr, ap);
  const bool active = h > 0 && tau > 0;
  // per contact: mass, J, trial acceleration, normal/tangent and the targets
  struct Row {
    double m, J[2][3], as[2], n[2], tg[2], dn, dtg, mus, mud;
  };
  std::vector<Row> rows(b.contacts.size());
  for (std::size_t k = 0; k < b.contacts.size(); ++k) {
    const auto& c = e.contacts[b.contacts[k]];
    Row& w = rows[k];
    w.m = e.mass[c.ix];
    w.J[0][0] = 1, w.J[0][1] = 0, w.J[0][2] = -(c.z - p.z);
    w.J[1][0] = 0, w.J[1][1] = 1, w.J[1][2] = c.x - p.x;
    // the free acceleration f/m without FLAC local damping: −α|f| sign(v) of a node pressed on
    // the body is a large force (f is balanced by the contact force) flipping with the sign of a
    // near-zero velocity, which the contact would pass on to the body as a chatter; a node in
    // contact is damped through its body (and by Rayleigh damping, which is in f)
    w.as[0] = e.f[c.ix] / w.m;
    w.as[1] = e.f[c.iz] / w.m;
    w.n[0] = c.nx, w.n[1] = c.nz, w.tg[0] = -c.nz, w.tg[1] = c.nx;
    double ub[2], vb[2];
    rigid_at(b.q, p, c.x, c.z, ub);
    rigid_at(b.qv, p, c.x, c.z, vb);
    const double du_rel[2] = {e.u[c.ix] - ub[0], e.u[c.iz] - ub[1]};
    const double dv[2] = {e.v[c.ix] - vb[0], e.v[c.iz] - vb[1]};
    const double g = w.n[0] * du_rel[0] + w.n[1] * du_rel[1]; // penetration positive
    const double vn = w.n[0] * dv[0] + w.n[1] * dv[1], vt = w.tg[0] * dv[0] + w.tg[1] * dv[1];
    w.dn = active ? -(g + h * vn) / (h * tau) : 0.0; // Carpenter et al. 1991, normal
    w.dtg = active ? -vt / tau : 0.0;                // stick: no relative tangential velocity
    const ContactPlane& cp = pb.contacts[c.plane];
    w.mus = cp.mu_static;
    w.mud = cp.mu_dynamic;
  }
  std::vector<int> status(rows.size());
  std::vector<double> sign(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    status[k] = active ? e.contacts[b.contacts[k]].status : 0;
    sign[k] = e.contacts[b.contacts[k]].sign;
  }
  double qa[3] = {ap[0], ap[1], ap[2]};
  // J_i q̈ (the body's surface acceleration at X_i)
  auto surface = [&](const Row& w, double out[2]) {
    for (int r = 0; r < 2; ++r) out[r] = w.J[r][0] * qa[0] + w.J[r][1] * qa[1] + w.J[r][2] * qa[2];
  };
  bool settled = false;
  for (int pass = 0; pass < 8; ++pass) {
    ++b.passes;
    double A[3][3], R[3];
    for (int a = 0; a < 3; ++a) {
      R[a] = Q[a];
      for (int c = 0; c < 3; ++c) A[a][c] = b.M[a][c];
    }
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const Row& w = rows[k];
      if (status[k] == 0) continue;
      if (status[k] == 1) { // stick: A += m JᵀJ, R −= m Jᵀ(d − a*)
        const double d[2] = {w.dn * w.n[0] + w.dtg * w.tg[0] - w.as[0],
                             w.dn * w.n[1] + w.dtg * w.tg[1] - w.as[1]};
        for (int a = 0; a < 3; ++a) {
          R[a] -= w.m * (w.J[0][a] * d[0] + w.J[1][a] * d[1]);
          for (int c = 0; c < 3; ++c)
            A[a][c] += w.m * (w.J[0][a] * w.J[0][c] + w.J[1][a] * w.J[1][c]);
        }
      } else { // slide: A −= m Jᵀw nᵀJ, R −= m Jᵀw (n·a* − d_n)
        const double ww[2] = {-w.n[0] + sign[k] * w.mud * w.tg[0],
                              -w.n[1] + sign[k] * w.mud * w.tg[1]};
        const double na = w.n[0] * w.as[0] + w.n[1] * w.as[1] - w.dn;
        for (int a = 0; a < 3; ++a) {
          const double Jw = w.J[0][a] * ww[0] + w.J[1][a] * ww[1];
          R[a] -= w.m * Jw * na;
          for (int c = 0; c < 3; ++c)
            A[a][c] -= w.m * Jw * (w.n[0] * w.J[0][c] + w.n[1] * w.J[1][c]);
        }
      }
    }
    double Af[3][3], Rf[3];
    for (int x = 0; x < nf; ++x) {
      Rf[x] = R[fr[x]];
      for (int c = 0; c < 3; ++c)
        if (reg.mode[c] != Region::Mode::Free) Rf[x] -= A[fr[x]][c] * ap[c];
      for (int y = 0; y < nf; ++y) Af[x][y] = A[fr[x]][fr[y]];
    }
    if (nf > 0) solve_small(nf, Af, Rf);
    for (int x = 0; x < nf; ++x) qa[fr[x]] = Rf[x];
    if (!active) {
      settled = true;
      break;
    }
    // the law of explicit_contacts with the relative trial acceleration a*_i − J_i q̈
    bool changed = false;
    std::vector<int> next(rows.size());
    std::vector<double> nsign(rows.size());
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const Row& w = rows[k];
      double js[2];
      surface(w, js);
      const double ar[2] = {w.as[0] - js[0], w.as[1] - js[1]};
      const double N = w.m * (w.n[0] * ar[0] + w.n[1] * ar[1] - w.dn);
      nsign[k] = sign[k];
      if (N <= 0.0) {
        next[k] = 0;
      } else {
        const double F = w.m * (w.dtg - (w.tg[0] * ar[0] + w.tg[1] * ar[1]));
        if (std::abs(F) > w.mus * N) {
          next[k] = 2;
          nsign[k] = F > 0 ? 1.0 : -1.0;
        } else {
          next[k] = 1;
        }
      }
      changed = changed || next[k] != status[k] || (next[k] == 2 && nsign[k] != sign[k]);
    }
    if (!changed) {
      settled = true;
      break;
    }
    if (pass == 7) break; // keep the forces of the last solve
    status = next;
    sign = nsign;
  }
  if (!settled) ++b.unsettled;
  // the forces of the last solve: on the soil nodes, and −Σ J_iᵀ r_i on the body (in q̈)
  for (std::size_t k = 0; k < rows.size(); ++k) {
    auto& c = e.contacts[b.contacts[k]];
    const Row& w = rows[k];
    double js[2], r[2] = {0.0, 0.0};
    surface(w, js);
    if (status[k] == 1) {
      for (int d = 0; d < 2; ++d) r[d] = w.m * (w.dn * w.n[d] + w.dtg * w.tg[d] - w.as[d] + js[d]);
    } else if (status[k] == 2) {
      const double N = w.m * (w.n[0] * (w.as[0] - js[0]) + w.n[1] * (w.as[1] - js[1]) - w.dn);
      for (int d = 0; d < 2; ++d) r[d] = N * (-w.n[d] + sign[k] * w.mud * w.tg[d]);
    }
    c.status = status[k];
    c.sign = sign[k];
    c.fx = r[0];
    c.fz = r[1];
    c.N = -(r[0] * w.n[0] + r[1] * w.n[1]);
    c.Ft = r[0] * w.tg[0] + r[1] * w.tg[1];
    c.slide = status[k] == 2;
    if (status[k] == 0) continue; // open: the free (damped) acceleration stays
    e.a[c.ix] = w.as[0] + r[0] / w.m;
    e.a[c.iz] = w.as[1] + r[1] / w.m;
  }
  for (int a = 0; a < 3; ++a) b.qa[a] = qa[a];
}

// Irons (1970): the largest eigenvalue of (K, M) is bounded by the largest element eigenvalue
// of (K_e, M_e). Per distinct cell (size, material): power iteration on M_e^{-1/2} K_e M_e^{-1/2}
// with the elastic tangent and the lumped element mass. Critical step of central differences:
// Δt = 2/ω_max, with stiffness-proportional damping β: (2/ω)(√(1 + ξ²) − ξ), ξ = βω/2 (Belytschko,
// Liu & Moran 2000 eq. 6.3.32).
double Model::Impl::explicit_stable_step() {
  FEValues<2> fv(mapping, fe, quad,
                 update_values | update_gradients | update_quadrature_points | update_JxW_values);
  const unsigned n = fe.n_dofs_per_cell();
  CellB cb;
  std::map<std::array<long long, 3>, double> cache;
  double lmax = 0.0;
  // A stress-dependent soil modulus: the eigenvalue scales with E, so the soil cells are bounded
  // with the largest factor of the soil's points (before they are set: the model's cap, which
  // run.cpp sets at the deepest geostatic stress)
  double fsoil = 1.0;
  const constitutive::Material& soil = models[0];
  if (soil.stiffness_from_stress() && stiffness_set) {
    double f = 0.0;
    for (const auto& s : committed) f = std::max(f, s.stiffness);
    fsoil = Utilities::MPI::max(f, comm);
  } else if (soil.stiffness_from_stress() && std::isfinite(soil.stiffness_cap())) {
    fsoil = soil.stiffness_cap();
  }
  for (const auto& cell : dof.active_cell_iterators()) {
    const auto id = cell->material_id();
    if (id > 0 && pb.regions[id - 1].rigid) continue;
    const auto dx = cell->vertex(1) - cell->vertex(0), dz = cell->vertex(2) - cell->vertex(0);
    const std::array<long long, 3> key{{std::llround(dx.norm() * 1e9),
                                        std::llround(dz.norm() * 1e9),
                                        (long long)(id)*2 + iface_cell[cell->active_cell_index()]}};
    const double scale = id == 0 ? fsoil : 1.0;
    if (auto it = cache.find(key); it != cache.end()) {
      lmax = std::max(lmax, scale * it->second);
      continue;
    }
    fv.reinit(cell);
    cell_b(fv, cb);
    const constitutive::VoigtMatrix C = models[id].elastic_tangent();
    FullMatrix<double> Ke(n, n);
    std::vector<double> m(n, 0.0);
    for (unsigned q = 0; q < nq(); ++q) {
      const double w = fv.JxW(q);
      for (unsigned i = 0; i < n; ++i) {
        m[i] += rho[id] * fv.shape_value(i, q) * w;
        double BiC[3] = {0, 0, 0};
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) BiC[b] += cb(i, q)[a] * C[a][b];
        for (unsigned j = 0; j < n; ++j)
          Ke(i, j) += (BiC[0] * cb(j, q)[0] + BiC[1] * cb(j, q)[1] + BiC[2] * cb(j, q)[2]) * w;
      }
    }
    // power iteration on S = D^{-1/2} K D^{-1/2}
    std::vector<double> x(n), y(n);
    for (unsigned i = 0; i < n; ++i) x[i] = 1.0 + 0.37 * i * ((i % 2) ? -1.0 : 1.0);
    double lam = 0.0;
    for (int it = 0; it < 500; ++it) {
      double nx = 0;
      for (double xi : x) nx += xi * xi;
      nx = std::sqrt(nx);
      for (double& xi : x) xi /= nx;
      for (unsigned i = 0; i < n; ++i) {
        double s = 0;
        for (unsigned j = 0; j < n; ++j) s += Ke(i, j) * x[j] / std::sqrt(m[i] * m[j]);
        y[i] = s;
      }
      double rq = 0;
      for (unsigned i = 0; i < n; ++i) rq += x[i] * y[i];
      const bool done = it > 20 && std::abs(rq - lam) <= 1e-10 * rq;
      lam = rq;
      x = y;
      if (done) break;
    }
    cache[key] = lam;
    lmax = std::max(lmax, scale * lam);
  }
  ex.omega_max = std::sqrt(lmax);
  const double w = ex.omega_max;
  if (w <= 0) return 1e300;
  const double xi = 0.5 * pb.rayleigh_beta * w;
  return pb.explicit_safety * 2.0 / w * (std::sqrt(1 + xi * xi) - xi);
}

// a = M⁻¹ (f_ext(t) − f_int(u) − C v) with the constraints (rigid bodies in their generalised
// coordinates, fixed and prescribed dofs at rest, u_i = u_j folded onto the master).
void Model::Impl::explicit_accel(double dt) {
  Explicit& e = ex;
  const std::size_t N = e.u.size();
  const unsigned n = e.n, nqp = e.nq;
  std::vector<double>& f = e.f;
  // external forces
  const double shake = pb.shaking_component >= 0 ? pb.shaking(t) : 0.0;
  for (std::size_t i = 0; i < N; ++i) f[i] = e.f_static[i] + shake * e.f_shake[i];
  for (std::size_t r = 0; r < pb.regions.size(); ++r) {
    const Region& reg = pb.regions[r];
    const double load[3] = {lambda * reg.force_x(t), lambda * reg.force_z(t),
                            lambda * reg.moment(t)};
    for (int k = 0; k < 3; ++k)
      if (load[k] != 0.0)
        for (std::size_t i = 0; i < N; ++i) f[i] += load[k] * e.f_region[r][k][i];
  }
  // internal forces cell by cell (this rank's cells): stress update at every point through the
  // constitutive seam, summed over the ranks below
  const double beta = pb.rayleigh_beta;
  std::vector<double>& fcell = e.f_int;
  std::fill(fcell.begin(), fcell.end(), 0.0);
  const auto t_cells = std::chrono::steady_clock::now();
  std::vector<double> ul(n), vl(n), fl(n);
  constitutive::State ns;
  const std::size_t ncell = e.cell_base.size();
  for (std::size_t c = 0; c < ncell; ++c) {
    const types::global_dof_index* ld = &e.cell_dofs[c * n];
    for (unsigned i = 0; i < n; ++i) ul[i] = e.u[ld[i]];
    if (beta > 0)
      for (unsigned i = 0; i < n; ++i) vl[i] = e.v[ld[i]];
    std::fill(fl.begin(), fl.end(), 0.0);
    const constitutive::Material& model = *e.cell_model[c];
    for (unsigned q = 0; q < nqp; ++q) {
      const double* B = &e.cell_B[(c * nqp + q) * n * 3];
      double eps[3] = {0, 0, 0}, rate[3] = {0, 0, 0};
      for (unsigned i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) eps[k] += ul[i] * B[3 * i + k];
      QpState& s = committed[e.cell_base[c] + q];
      const constitutive::Voigt de{{eps[0] - s.eps[0], eps[1] - s.eps[1], eps[2] - s.eps[2]}};
      model.update(s, de, ns, nullptr);
      static_cast<constitutive::State&>(s) = ns;
      s.eps = {{eps[0], eps[1], eps[2]}};
      double sig[3] = {ns.stress[0], ns.stress[1], ns.stress[2]};
      if (beta > 0) { // stiffness-proportional Rayleigh damping stress β De ε̇
        for (unsigned i = 0; i < n; ++i)
          for (int k = 0; k < 3; ++k) rate[k] += vl[i] * B[3 * i + k];
        const constitutive::VoigtMatrix& De = e.cell_De[c];
        const double bf = beta * s.stiffness; // the point's modulus (stress-dependent)
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) sig[a] += bf * De[a][b] * rate[b];
      }
      const double w = e.cell_w[c * nqp + q];
      for (unsigned i = 0; i < n; ++i)
        fl[i] += (B[3 * i] * sig[0] + B[3 * i + 1] * sig[1] + B[3 * i + 2] * sig[2]) * w;
    }
    for (unsigned i = 0; i < n; ++i) fcell[ld[i]] += fl[i];
  }
  const auto t_reduce = std::chrono::steady_clock::now();
  allreduce_sum(fcell, comm); // the ranks' parts at the dofs they share (one rank: nothing)
  const auto t_nodal = std::chrono::steady_clock::now();
  e.cells_s += std::chrono::duration<double>(t_reduce - t_cells).count();
  e.reduce_s += std::chrono::duration<double>(t_nodal - t_reduce).count();
  for (std::size_t i = 0; i < N; ++i) f[i] -= fcell[i];
  // viscous damping (mass-proportional, dashpots) with the current velocity
  for (std::size_t i = 0; i < N; ++i) f[i] -= e.damp[i] * e.v[i];
  // fold u_i = u_j
  for (const auto& [i, j] : e.follows) f[j] += f[i];
  // free dofs, with FLAC-style local damping f_d = −α |f| sign(v) (Cundall 1987)
  const double al = pb.local_damping;
  for (std::size_t i = 0; i < N; ++i) {
    if (e.kind[i] != 0) {
      if (e.kind[i] != 3 && e.kind[i] != 4) e.a[i] = 0.0;
      continue;
    }
    double fi = f[i];
    if (al > 0 && e.v[i] != 0.0) fi -= al * std::abs(fi) * (e.v[i] > 0 ? 1.0 : -1.0);
    e.a[i] = fi / e.mass[i];
  }
  for (const auto& [i, j] : e.follows) e.a[i] = e.a[j];
  if (!e.contacts.empty()) explicit_contacts();
  // rigid bodies: M_q a_q = F_q, F_q = Σ row_i f_i; fixed components at rest, prescribed ones
  // with the motion's acceleration (second difference), free ones solved for
  for (auto& b : e.bodies) {
    if (b.contact) {
      explicit_contact_body(b, dt);
      continue;
    }
    const Region& reg = pb.regions[b.region];
    double F[3] = {0, 0, 0};
    for (std::size_t k = 0; k < b.dofs.size(); ++k)
      for (int a = 0; a < 3; ++a) F[a] += b.rows[k][a] * f[b.dofs[k]];
    double ap[3] = {0, 0, 0};
    int fr[3];
    const int nf = free_and_prescribed(reg, t, dt, fr, ap);
    double A[3][3], F_f[3];
    for (int x = 0; x < nf; ++x) {
      F_f[x] = F[fr[x]];
      for (int c = 0; c < 3; ++c)
        if (reg.mode[c] != Region::Mode::Free) F_f[x] -= b.M[fr[x]][c] * ap[c];
      for (int y = 0; y < nf; ++y) A[x][y] = b.M[fr[x]][fr[y]];
    }
    if (nf > 0) solve_small(nf, A, F_f);
    for (int a = 0; a < 3; ++a) b.qa[a] = ap[a];
    for (int x = 0; x < nf; ++x) b.qa[fr[x]] = F_f[x];
    for (std::size_t k = 0; k < b.dofs.size(); ++k) {
      const auto& rw = b.rows[k];
      e.a[b.dofs[k]] = rw[0] * b.qa[0] + rw[1] * b.qa[1] + rw[2] * b.qa[2];
    }
  }
}

// One step of the central-difference method in velocity-Verlet form (Belytschko, Liu & Moran
// 2000 Box 6.1): v_{n+½} = v_n + ½Δt a_n, u_{n+1} = u_n + Δt v_{n+½}, a_{n+1} from u_{n+1} (and
// the damping forces of v_{n+½}), v_{n+1} = v_{n+½} + ½Δt a_{n+1}.
void Model::Impl::explicit_move(double dt) {
  Explicit& e = ex;
  const std::size_t N = e.u.size();
  const auto t_start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < N; ++i)
    if (e.kind[i] == 0) {
      e.v[i] += 0.5 * dt * e.a[i];
      e.u[i] += dt * e.v[i];
    }
  for (const auto& [i, j] : e.follows) {
    e.v[i] = e.v[j];
    e.u[i] = e.u[j];
  }
  for (auto& b : e.bodies) {
    const Region& reg = pb.regions[b.region];
    for (int a = 0; a < 3; ++a) {
      if (reg.mode[a] == Region::Mode::Free) {
        b.qv[a] += 0.5 * dt * b.qa[a];
        b.q[a] += dt * b.qv[a];
      } else if (reg.mode[a] == Region::Mode::Prescribed) {
        b.q_prev[a] = b.q[a];
        b.q[a] = reg.motion[a](t + dt);
        b.qv[a] = (b.q[a] - b.q_prev[a]) / dt;
      } else {
        b.q[a] = b.qv[a] = 0.0;
      }
    }
    for (std::size_t k = 0; k < b.dofs.size(); ++k) {
      const auto& rw = b.rows[k];
      e.u[b.dofs[k]] = rw[0] * b.q[0] + rw[1] * b.q[1] + rw[2] * b.q[2];
      e.v[b.dofs[k]] = rw[0] * b.qv[0] + rw[1] * b.qv[1] + rw[2] * b.qv[2];
    }
  }
  t += dt;
  e.contact_dt = e.contact_tau = dt;
  explicit_accel(dt);
  for (std::size_t i = 0; i < N; ++i)
    if (e.kind[i] == 0) e.v[i] += 0.5 * dt * e.a[i];
  for (const auto& [i, j] : e.follows) e.v[i] = e.v[j];
  for (auto& b : e.bodies) {
    const Region& reg = pb.regions[b.region];
    for (int a = 0; a < 3; ++a)
      if (reg.mode[a] == Region::Mode::Free) b.qv[a] += 0.5 * dt * b.qa[a];
    for (std::size_t k = 0; k < b.dofs.size(); ++k) {
      const auto& rw = b.rows[k];
      e.v[b.dofs[k]] = rw[0] * b.qv[0] + rw[1] * b.qv[1] + rw[2] * b.qv[2];
    }
  }
  // work of the contact forces on the soil over the step around t_{n+1}: Δt f·(v_{n+1} − the
  // plane's velocity there; a moving body's surface velocity J q̇), the frictional and separation
  // work of the interface (the body's own work is in its motion)
  for (const auto& c : e.contacts) {
    double vb[2] = {0.0, 0.0};
    if (c.body >= 0) {
      const auto& b = e.bodies[c.body];
      rigid_at(b.qv, pb.regions[b.region].pivot, c.x, c.z, vb);
    }
    e.contact_work[c.plane] += dt * (c.fx * (e.v[c.ix] - vb[0]) + c.fz * (e.v[c.iz] - vb[1]));
  }
  ++e.steps;
  e.step_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
}

void Model::Impl::explicit_sync() {
  for (const auto i : owned) {
    u(i) = ex.u[i];
    v(i) = ex.v[i];
    acc(i) = ex.a[i];
  }
  u.compress(VectorOperation::insert);
  v.compress(VectorOperation::insert);
  acc.compress(VectorOperation::insert);
  a_n = acc;
  trial = committed;
}

StepStats Model::Impl::explicit_advance(double dt) {
  StepStats st;
  lambda = 1.0;
  const bool init = !ex.ready;
  if (init) explicit_setup();
  double h = ex.dt_stable;
  if (pb.explicit_dt > 0) {
    if (pb.explicit_dt > ex.dt_stable)
      throw std::runtime_error(
          "explicit time step " + std::to_string(pb.explicit_dt) + " s exceeds the stable step " +
          std::to_string(ex.dt_stable) + " s (" + std::to_string(pb.explicit_safety) +
          " × 2/ω_max); give a smaller continuum.dt or 0 for the automatic step");
    h = pb.explicit_dt;
  }
  const long k = std::max(1L, static_cast<long>(std::ceil(dt / h - 1e-9)));
  if (init) {
    // a_0 = M⁻¹(f_ext − f_int(u_0) − C v_0); contact looks ahead over the first step, whose
    // velocity update v_½ = v_0 + ½Δt a_0 is a half step
    ex.contact_dt = dt / double(k);
    ex.contact_tau = 0.5 * ex.contact_dt;
    explicit_accel(0.0);
    dyn_init = true;
  }
  for (long s = 0; s < k; ++s) explicit_move(dt / double(k));
  st.substeps = k;
  double norm = 0;
  for (double x : ex.u) norm += x * x;
  if (!std::isfinite(norm)) {
    st.converged = false;
    log << "explicit integration diverged at t=" << t << "\n";
  }
  explicit_sync();
  return st;
}

std::vector<Model::Impl::Explicit::Contact> Model::Impl::contact_state(std::size_t plane) const {
  std::vector<Explicit::Contact> out;
  if (ex.ready) {
    for (const auto& c : ex.contacts)
      if (c.plane == plane) out.push_back(c);
    return out;
  }
  // before the explicit run (K0 state, seating): the reactions of the constraints that hold the
  // nodes on the plane, f_int − f_ext at their dofs (the force of the soil on the support)
  // (collective: each rank reads the reactions at its owned dofs, the sum gives every rank all)
  const auto nodes = contact_nodes();
  const auto& on_plane = nodes.at(plane);
  // a node at a corner of a structure (on two of its faces) carries one reaction: it counts on
  // the structure's first face only (as explicit_contact_setup keeps one contact per node)
  std::set<types::global_dof_index> earlier;
  const int region = pb.contacts.at(plane).region;
  for (std::size_t k = 0; region >= 0 && k < plane; ++k)
    if (pb.contacts[k].region == region)
      for (const ContactNode& n : nodes[k]) earlier.insert(n.ix);
  std::vector<double> r(2 * on_plane.size(), 0.0);
  for (std::size_t k = 0; k < on_plane.size(); ++k) {
    const ContactNode& n = on_plane[k];
    r[2 * k] = owned.is_element(n.ix) && hom.is_constrained(n.ix) ? res(n.ix) : 0.0;
    r[2 * k + 1] = owned.is_element(n.iz) && hom.is_constrained(n.iz) ? res(n.iz) : 0.0;
  }
  allreduce_sum(r, comm);
  for (std::size_t k = 0; k < on_plane.size(); ++k) {
    const ContactNode& n = on_plane[k];
    if (earlier.count(n.ix)) continue;
    Explicit::Contact c = contact_at(n, plane);
    const double rx = r[2 * k], rz = r[2 * k + 1];
    c.fx = rx; // the plane's force on the soil: f_int − f_ext at a held dof
    c.fz = rz;
    c.N = -(c.fx * c.nx + c.fz * c.nz);
    c.Ft = c.fx * -c.nz + c.fz * c.nx;
    if (c.N <= 0.0) c.fx = c.fz = c.N = c.Ft = 0.0;
    out.push_back(c);
  }
  return out;
}

ContactForce Model::contact_force(std::size_t plane) const {
  const Impl& m = *impl_;
  const ContactPlane& p = m.pb.contacts.at(plane);
  ContactForce out;
  Point pivot;
  if (p.region >= 0) pivot = m.pb.regions.at(static_cast<std::size_t>(p.region)).pivot;
  for (const auto& c : m.contact_state(plane)) {
    if (m.ex.ready) {
      double ub[2] = {0.0, 0.0}; // a moving body's surface displacement under the node
      if (c.body >= 0) {
        const auto& b = m.ex.bodies[c.body];
        rigid_at(b.q, m.pb.regions[b.region].pivot, c.x, c.z, ub);
      }
      const double ut = -c.nz * (m.ex.u[c.ix] - ub[0]) + c.nx * (m.ex.u[c.iz] - ub[1]);
      out.max_slip = std::max(out.max_slip, std::abs(ut));
    }
    if (c.N <= 0.0) {
      ++out.open;
      continue;
    }
    ++out.nodes;
    out.sliding += c.slide ? 1 : 0;
    out.fx -= c.fx; // the soil pushes the plane with −(the plane's force on it)
    out.fz -= c.fz;
    out.moment += -(c.x - pivot.x) * c.fz + (c.z - pivot.z) * c.fx; // (X − p) × (−f)
    out.normal += c.N;
    out.tangential += std::abs(c.Ft);
  }
  if (plane < m.ex.contact_work.size()) out.dissipated = -m.ex.contact_work[plane];
  return out;
}

Model::Momentum Model::momentum() const {
  const Impl& m = *impl_;
  Momentum out;
  if (!m.ex.ready) return out;
  // soil: Σ m_i v_i and Σ m_i (X_i × v_i)_y at the nodes' reference positions (a periodic
  // follower's mass is its master's: skipped)
  const auto& usp = m.fe.get_unit_support_points();
  std::vector<types::global_dof_index> ld(m.fe.n_dofs_per_cell());
  std::vector<char> seen(m.ex.u.size(), 0);
  for (const auto& cell : m.dof.active_cell_iterators()) {
    cell->get_dof_indices(ld);
    for (unsigned k = 0; k < ld.size(); ++k) {
      const auto i = ld[k];
      if (seen[i] || m.ex.kind[i] == 3) continue;
      seen[i] = 1;
      const double p = m.ex.mass[i] * m.ex.v[i];
      const auto X = m.mapping.transform_unit_to_real_cell(cell, usp[k]);
      if (m.fe.system_to_component_index(k).first == 0) {
        out.px += p;
        out.angular -= X[1] * p; // counter-clockwise (as the rotation): x v_z − z v_x
      } else {
        out.pz += p;
        out.angular += X[0] * p;
      }
    }
  }
  // contact bodies: M_q q̇ = (P_x, P_z, L_p); L_0 = L_p + p × P
  for (const auto& b : m.ex.bodies) {
    if (!b.contact) continue;
    double P[3] = {0, 0, 0};
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < 3; ++c) P[a] += b.M[a][c] * b.qv[c];
    const Point& p = m.pb.regions[b.region].pivot;
    out.px += P[0];
    out.pz += P[1];
    out.angular += P[2] + p.x * P[1] - p.z * P[0];
  }
  return out;
}

std::string Model::contact_body_summary() const {
  const Impl& m = *impl_;
  std::ostringstream s;
  for (const auto& b : m.ex.bodies) {
    if (!b.contact) continue;
    const long steps = std::max(1L, m.ex.steps);
    s << "contact body '" << m.pb.regions[b.region].name << "': " << b.contacts.size()
      << " soil nodes in Coulomb contact with its faces, " << double(b.passes) / double(steps)
      << " active-set passes per step, " << b.unsettled << " of " << m.ex.steps
      << " steps ended with an unsettled set (8 passes)\n";
  }
  return s.str();
}

double stable_time_step(const Problem& pb) {
  Model::Impl lite(pb, true);
  return lite.explicit_stable_step();
}

Model::ExplicitProfile Model::explicit_profile() const {
  const Impl& m = *impl_;
  ExplicitProfile p;
  p.steps = m.ex.steps;
  p.ranks = static_cast<int>(Utilities::MPI::n_mpi_processes(m.comm));
  p.cells = m.ex.cell_base.size();
  p.cells_s = m.ex.cells_s;
  p.reduce_s = m.ex.reduce_s;
  p.nodal_s = std::max(0.0, m.ex.step_s - m.ex.cells_s - m.ex.reduce_s);
  return p;
}

double Model::stable_time_step() {
  Impl& m = *impl_;
  if (!m.ex.ready) return m.explicit_stable_step();
  return m.ex.dt_stable;
}

} // namespace demfem::continuum::fem
