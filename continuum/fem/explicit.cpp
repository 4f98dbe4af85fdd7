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

namespace explicit_detail {

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

void allreduce_sum(std::vector<double>& x, MPI_Comm comm) {
  if (Utilities::MPI::n_mpi_processes(comm) == 1 || x.empty()) return;
  const int rc =
      MPI_Allreduce(MPI_IN_PLACE, x.data(), static_cast<int>(x.size()), MPI_DOUBLE, MPI_SUM, comm);
  AssertThrowMPI(rc);
}

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

} // namespace explicit_detail
using namespace explicit_detail;

void Explicit::setup() {
  const Problem& pb = core.pb;
  State& e = state;
  const bool several = Utilities::MPI::n_mpi_processes(core.comm) > 1;
  const std::size_t N = core.dof.n_dofs();
  const unsigned n = core.fe.n_dofs_per_cell();
  e.n = n;
  e.nq = core.nq();
  for (auto* w : {&e.u, &e.v, &e.a, &e.f, &e.f_int, &e.mass, &e.damp, &e.f_static, &e.f_shake})
    w->assign(N, 0.0);
  e.f_region.assign(pb.regions.size(), {});
  for (auto& fr : e.f_region)
    for (auto& w : fr) w.assign(N, 0.0);
  // the current state (the K0 state at rest, or a set displacement): each rank has its owned
  // entries, the others are 0, so the sum over the ranks is exact
  for (const auto i : core.owned) {
    e.u[i] = core.u(i);
    e.v[i] = core.v(i);
  }
  allreduce_sum(e.u, core.comm);
  allreduce_sum(e.v, core.comm);

  FEValues<2> fv(core.mapping, core.fe, core.quad,
                 update_values | update_gradients | update_quadrature_points | update_JxW_values);
  FEFaceValues<2> ffv(core.mapping, core.fe, core.face_quad,
                      update_values | update_quadrature_points | update_normal_vectors |
                          update_JxW_values);
  std::vector<types::global_dof_index> ld(n);
  CellB cb;
  e.cell_dofs.clear();
  e.cell_B.clear();
  e.cell_w.clear();
  e.cell_base.clear();
  e.cell_model.clear();
  e.cell_De.clear();
  for (const auto& cell : core.dof.active_cell_iterators()) {
    fv.reinit(cell);
    cell->get_dof_indices(ld);
    const auto id = cell->material_id();
    const bool rigid_cell = id > 0 && pb.regions[id - 1].rigid;
    const double r = core.rho[id];
    for (unsigned q = 0; q < core.nq(); ++q) {
      const double w = fv.JxW(q);
      const auto xq = fv.quadrature_point(q);
      // body forces: gravity along −z (structures' weight if dead_weight), base shaking ρ·a(t)
      // per unit acceleration (soil only, as in assemble), structure loads per unit
      // resultant/moment (as in assemble)
      const bool weight = id == 0 || pb.regions[id - 1].dead_weight;
      const double gz = weight ? -r * pb.gravity * core.gfactor * core.weight_factor(id) : 0.0;
      double unit[3][2] = {{0, 0}, {0, 0}, {0, 0}};
      if (id > 0) {
        const RegionGeom& g = core.geom[id];
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
        const unsigned ci = core.fe.system_to_component_index(i).first;
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
      core.add_tractions(cell, f, ffv, [&](unsigned i, double fi) { e.f_static[ld[i]] += fi; });
      // Lysmer & Kuhlemeyer (1969) dashpots, lumped: c_i = ∫ N_i ρ (c_p n_i² + c_s (1 − n_i²))
      const auto bid = cell->face(f)->boundary_id();
      if (!pb.absorbing || bid > 3 || !pb.absorbing_sides[bid]) continue;
      ffv.reinit(cell, f);
      const constitutive::Hooke& P = core.models[id].elasticity().hooke;
      const double G = P.shear_modulus(), lam = P.lame();
      const double cp = std::sqrt((lam + 2 * G) / r), cs = std::sqrt(G / r);
      for (unsigned q = 0; q < ffv.n_quadrature_points; ++q) {
        const auto nrm = ffv.normal_vector(q);
        for (unsigned i = 0; i < n; ++i) {
          const unsigned ci = core.fe.system_to_component_index(i).first;
          const double n2 = nrm[ci] * nrm[ci];
          e.damp[ld[i]] += ffv.shape_value(i, q) * r * (cp * n2 + cs * (1 - n2)) * ffv.JxW(q);
        }
      }
    }
    if (rigid_cell) continue; // a small rigid motion has no strain: no stress, no internal force
    // the masses and loads above come from every cell on every rank (identical sums); stresses
    // and internal forces only from this rank's cells (their states are updated here only)
    if (!cell->is_locally_owned()) continue;
    core.cell_b(fv, cb);
    e.cell_base.push_back(cell->active_cell_index() * core.nq());
    e.cell_model.push_back(&core.model_of(cell->active_cell_index(), id));
    e.cell_De.push_back(core.models[id].elastic_tangent());
    for (unsigned i = 0; i < n; ++i) e.cell_dofs.push_back(ld[i]);
    for (unsigned q = 0; q < core.nq(); ++q) {
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
    if (core.rigid[r].is_dof.empty()) continue;
    Body b;
    b.region = r;
    const Region& reg = pb.regions[r];
    for (const auto& [i, cp] : core.rigid[r].dofs) {
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
      for (int j = 0; j < 3; ++j) b.q[a] += core.rigid[r].T[a][j] * e.u[core.rigid[r].master[j]];
    for (int a = 0; a < 3; ++a) b.q_prev[a] = b.q[a];
    e.bodies.push_back(std::move(b));
  }
  // moving structures in Coulomb contact (Region::contact, a DoF not fixed): unmeshed rigid
  // bodies whose faces are moving contact planes (contact_body)
  for (std::size_t r = 0; r < pb.regions.size(); ++r) {
    const Region& reg = pb.regions[r];
    if (!reg.contact || (reg.mode[0] == Region::Mode::Fixed && reg.mode[1] == Region::Mode::Fixed &&
                         reg.mode[2] == Region::Mode::Fixed))
      continue;
    Body b;
    b.region = r;
    b.contact = true;
    const RegionGeom& g = core.geom[r + 1];
    if (g.area <= 0.0 || core.rho[r + 1] <= 0.0)
      throw std::runtime_error("structure '" + reg.name +
                               "' in Coulomb contact has no mass (its "
                               "outline's area × density is 0)");
    const double m = core.rho[r + 1] * g.area, dx = g.xc - reg.pivot.x, dz = g.zc - reg.pivot.z;
    // M_q = ∫ ρ Sᵀ S dA with S = [[1, 0, −(z − zp)], [0, 1, x − xp]] (small rigid motion about
    // the pivot): m, static moments m (x_c − x_p), m (z_c − z_p) and the polar moment about the
    // pivot ρ (J_c + A |c − p|²) (parallel-axis theorem)
    b.M[0][0] = b.M[1][1] = m;
    b.M[0][2] = b.M[2][0] = -m * dz;
    b.M[1][2] = b.M[2][1] = m * dx;
    b.M[2][2] = core.rho[r + 1] * (g.J + g.area * (dx * dx + dz * dz));
    // dead weight −m g at the centroid (as the tied body's cells get it): Q = Sᵀ(c) (0, −m g)
    const double W = reg.dead_weight ? m * pb.gravity * core.gfactor *
                                           core.weight_factor(types::material_id(r + 1))
                                     : 0.0;
    b.Qw[1] = -W;
    b.Qw[2] = -W * dx;
    e.bodies.push_back(std::move(b));
  }
  // `hom` knows the locally relevant dofs only: each rank classifies its owned dofs, and the
  // classes are gathered below (one rank: all dofs are owned)
  bool unsupported = false;
  for (std::size_t i = 0; i < N; ++i) {
    if (e.kind[i] == 4 || !core.owned.is_element(i) || !core.hom.is_constrained(i)) continue;
    const auto it = core.lines.find(i);
    if (it != core.lines.end() && it->second.target) {
      e.kind[i] = 2;
      e.prescribed.emplace_back(i, it->second.target());
      continue;
    }
    const auto* entries = core.hom.get_constraint_entries(i);
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
  if (several) gather_classes();
  for (const auto& [i, j] : e.follows) // (a master classified on another rank)
    unsupported = unsupported || e.kind[j] != 0;
  if (Utilities::MPI::max(unsupported ? 1 : 0, core.comm) != 0) // refused on every rank together
    throw std::runtime_error("the explicit integrator supports only u_i = u_j constraints "
                             "(periodic sides) besides rigid bodies and fixed dofs");
  // u_i = u_j: condensed mass and damping of the master
  for (const auto& [i, j] : e.follows) {
    e.mass[j] += e.mass[i];
    e.damp[j] += e.damp[i];
  }
  for (const auto& [i, val] : e.prescribed) e.u[i] = val;
  contact_setup();
  // every rank bounds every cell (the whole shared mesh): the same step; the reduction keeps it so
  e.dt_stable = Utilities::MPI::min(stable_step(), core.comm);
  e.omega_max = Utilities::MPI::max(e.omega_max, core.comm);
  e.ready = true;
  core.log << "explicit: " << N << " dofs, " << Utilities::MPI::sum(e.cell_base.size(), core.comm)
           << " cells with stresses";
  if (several)
    core.log << " (" << e.cell_base.size() << " on rank "
             << Utilities::MPI::this_mpi_process(core.comm) << " of "
             << Utilities::MPI::n_mpi_processes(core.comm) << ")";
  core.log << ", " << e.bodies.size() << " rigid bodies, " << e.contacts.size()
           << " Coulomb contact nodes, ω_max ≤ " << e.omega_max << " rad/s, Δt = " << e.dt_stable
           << " s (" << pb.explicit_safety << " of the critical step)\n";
}

// Several ranks: every rank classified its owned dofs (fixed, prescribed with their value, periodic
// with their master; `contact_roller`); the sums over the ranks (each dof has one owner, the others
// give 0) give every rank all of them, listed in dof order as on one rank. Rigid-body dofs are
// classified on every rank already.
void Explicit::gather_classes() {
  State& e = state;
  const std::size_t N = e.kind.size();
  std::vector<double> buf(4 * N, 0.0); // class, prescribed value, master + 1, roller
  for (const auto i : core.owned)
    if (e.kind[i] != 4) {
      buf[i] = e.kind[i];
      buf[3 * N + i] = core.contact_roller[i];
    }
  for (const auto& [i, x] : e.prescribed) buf[N + i] = x;
  for (const auto& [i, j] : e.follows) buf[2 * N + i] = double(j) + 1.0;
  allreduce_sum(buf, core.comm);
  e.prescribed.clear();
  e.follows.clear();
  for (std::size_t i = 0; i < N; ++i) {
    core.contact_roller[i] = buf[3 * N + i] != 0.0;
    if (e.kind[i] == 4) continue;
    e.kind[i] = static_cast<char>(buf[i]);
    if (e.kind[i] == 2) e.prescribed.emplace_back(i, buf[N + i]);
    if (e.kind[i] == 3)
      e.follows.emplace_back(i, static_cast<types::global_dof_index>(buf[2 * N + i] - 1.0));
  }
}

// Irons (1970): the largest eigenvalue of (K, M) is bounded by the largest element eigenvalue
// of (K_e, M_e). Per distinct cell (size, material): power iteration on M_e^{-1/2} K_e M_e^{-1/2}
// with the elastic tangent and the lumped element mass. Critical step of central differences:
// Δt = 2/ω_max, with stiffness-proportional damping β: (2/ω)(√(1 + ξ²) − ξ), ξ = βω/2 (Belytschko,
// Liu & Moran 2000 eq. 6.3.32).
double Explicit::stable_step() {
  const Problem& pb = core.pb;
  FEValues<2> fv(core.mapping, core.fe, core.quad,
                 update_values | update_gradients | update_quadrature_points | update_JxW_values);
  const unsigned n = core.fe.n_dofs_per_cell();
  CellB cb;
  std::map<std::array<long long, 3>, double> cache;
  double lmax = 0.0;
  // A stress-dependent soil modulus: the eigenvalue scales with E, so the soil cells are bounded
  // with the largest factor of the soil's points (before they are set: the model's cap, which
  // run.cpp sets at the deepest geostatic stress)
  double fsoil = 1.0;
  const constitutive::Material& soil = core.models[0];
  if (soil.stiffness_from_stress() && core.stiffness_set) {
    double f = 0.0;
    for (const auto& s : core.committed) f = std::max(f, s.stiffness);
    fsoil = Utilities::MPI::max(f, core.comm);
  } else if (soil.stiffness_from_stress() && std::isfinite(soil.stiffness_cap())) {
    fsoil = soil.stiffness_cap();
  }
  for (const auto& cell : core.dof.active_cell_iterators()) {
    const auto id = cell->material_id();
    if (id > 0 && pb.regions[id - 1].rigid) continue;
    const auto dx = cell->vertex(1) - cell->vertex(0), dz = cell->vertex(2) - cell->vertex(0);
    const std::array<long long, 3> key{
        {std::llround(dx.norm() * 1e9), std::llround(dz.norm() * 1e9),
         (long long)(id)*2 + core.iface_cell[cell->active_cell_index()]}};
    const double scale = id == 0 ? fsoil : 1.0;
    if (auto it = cache.find(key); it != cache.end()) {
      lmax = std::max(lmax, scale * it->second);
      continue;
    }
    fv.reinit(cell);
    core.cell_b(fv, cb);
    const constitutive::VoigtMatrix C = core.models[id].elastic_tangent();
    FullMatrix<double> Ke(n, n);
    std::vector<double> m(n, 0.0);
    for (unsigned q = 0; q < core.nq(); ++q) {
      const double w = fv.JxW(q);
      for (unsigned i = 0; i < n; ++i) {
        m[i] += core.rho[id] * fv.shape_value(i, q) * w;
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
  state.omega_max = std::sqrt(lmax);
  const double w = state.omega_max;
  if (w <= 0) return 1e300;
  const double xi = 0.5 * pb.rayleigh_beta * w;
  return pb.explicit_safety * 2.0 / w * (std::sqrt(1 + xi * xi) - xi);
}

// a = M⁻¹ (f_ext(t) − f_int(u) − C v) with the constraints (rigid bodies in their generalised
// coordinates, fixed and prescribed dofs at rest, u_i = u_j folded onto the master).
void Explicit::accel(double dt) {
  const Problem& pb = core.pb;
  State& e = state;
  const std::size_t N = e.u.size();
  const unsigned n = e.n, nqp = e.nq;
  std::vector<double>& f = e.f;
  // external forces
  const double shake = pb.shaking_component >= 0 ? pb.shaking(core.t) : 0.0;
  for (std::size_t i = 0; i < N; ++i) f[i] = e.f_static[i] + shake * e.f_shake[i];
  for (std::size_t r = 0; r < pb.regions.size(); ++r) {
    const Region& reg = pb.regions[r];
    const double load[3] = {core.lambda * reg.force_x(core.t), core.lambda * reg.force_z(core.t),
                            core.lambda * reg.moment(core.t)};
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
      QpState& s = core.committed[e.cell_base[c] + q];
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
  allreduce_sum(fcell, core.comm); // the ranks' parts at the dofs they share (one rank: nothing)
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
  if (!e.contacts.empty()) apply_contacts();
  // rigid bodies: M_q a_q = F_q, F_q = Σ row_i f_i; fixed components at rest, prescribed ones
  // with the motion's acceleration (second difference), free ones solved for
  for (auto& b : e.bodies) {
    if (b.contact) {
      contact_body(b, dt);
      continue;
    }
    const Region& reg = pb.regions[b.region];
    double F[3] = {0, 0, 0};
    for (std::size_t k = 0; k < b.dofs.size(); ++k)
      for (int a = 0; a < 3; ++a) F[a] += b.rows[k][a] * f[b.dofs[k]];
    double ap[3] = {0, 0, 0};
    int fr[3];
    const int nf = free_and_prescribed(reg, core.t, dt, fr, ap);
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
void Explicit::move(double dt) {
  const Problem& pb = core.pb;
  State& e = state;
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
        b.q[a] = reg.motion[a](core.t + dt);
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
  core.t += dt;
  e.contact_dt = e.contact_tau = dt;
  accel(dt);
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

void Explicit::sync() {
  for (const auto i : core.owned) {
    core.u(i) = state.u[i];
    core.v(i) = state.v[i];
    core.acc(i) = state.a[i];
  }
  core.u.compress(VectorOperation::insert);
  core.v.compress(VectorOperation::insert);
  core.acc.compress(VectorOperation::insert);
  core.trial = core.committed;
}

StepStats Explicit::advance(double dt) {
  const Problem& pb = core.pb;
  StepStats st;
  core.lambda = 1.0;
  const bool init = !state.ready;
  if (init) setup();
  double h = state.dt_stable;
  if (pb.explicit_dt > 0) {
    if (pb.explicit_dt > state.dt_stable)
      throw std::runtime_error(
          "explicit time step " + std::to_string(pb.explicit_dt) + " s exceeds the stable step " +
          std::to_string(state.dt_stable) + " s (" + std::to_string(pb.explicit_safety) +
          " × 2/ω_max); give a smaller continuum.dt or 0 for the automatic step");
    h = pb.explicit_dt;
  }
  const long k = std::max(1L, static_cast<long>(std::ceil(dt / h - 1e-9)));
  if (init) {
    // a_0 = M⁻¹(f_ext − f_int(u_0) − C v_0); contact looks ahead over the first step, whose
    // velocity update v_½ = v_0 + ½Δt a_0 is a half step
    state.contact_dt = dt / double(k);
    state.contact_tau = 0.5 * state.contact_dt;
    accel(0.0);
    core.dyn_init = true;
  }
  for (long s = 0; s < k; ++s) move(dt / double(k));
  st.substeps = k;
  double norm = 0;
  for (double x : state.u) norm += x * x;
  if (!std::isfinite(norm)) {
    st.converged = false;
    core.log << "explicit integration diverged at t=" << core.t << "\n";
  }
  sync();
  return st;
}

Model::Momentum Model::momentum() const {
  const Impl& m = *impl_;
  Momentum out;
  if (!m.ex.state.ready) return out;
  // soil: Σ m_i v_i and Σ m_i (X_i × v_i)_y at the nodes' reference positions (a periodic
  // follower's mass is its master's: skipped)
  const auto& usp = m.fe.get_unit_support_points();
  std::vector<types::global_dof_index> ld(m.fe.n_dofs_per_cell());
  std::vector<char> seen(m.ex.state.u.size(), 0);
  for (const auto& cell : m.dof.active_cell_iterators()) {
    cell->get_dof_indices(ld);
    for (unsigned k = 0; k < ld.size(); ++k) {
      const auto i = ld[k];
      if (seen[i] || m.ex.state.kind[i] == 3) continue;
      seen[i] = 1;
      const double p = m.ex.state.mass[i] * m.ex.state.v[i];
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
  for (const auto& b : m.ex.state.bodies) {
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

double stable_time_step(const Problem& pb) {
  Model::Impl lite(pb, true);
  return lite.ex.stable_step();
}

Model::ExplicitProfile Model::explicit_profile() const {
  const Impl& m = *impl_;
  ExplicitProfile p;
  p.steps = m.ex.state.steps;
  p.ranks = static_cast<int>(Utilities::MPI::n_mpi_processes(m.comm));
  p.cells = m.ex.state.cell_base.size();
  p.cells_s = m.ex.state.cells_s;
  p.reduce_s = m.ex.state.reduce_s;
  p.nodal_s = std::max(0.0, m.ex.state.step_s - m.ex.state.cells_s - m.ex.state.reduce_s);
  return p;
}

double Model::stable_time_step() {
  Impl& m = *impl_;
  if (!m.ex.state.ready) return m.ex.stable_step();
  return m.ex.state.dt_stable;
}

} // namespace demfem::continuum::fem
