// Assembly: B-bar strain rows and strains, body forces (Core); the implicit system: mass and
// elastic stiffness matrices, residual and tangent (Implicit). The tractions: Core::add_tractions.
#include "impl.hpp"

namespace demfem::continuum::fem {

void Core::cell_b(const FEValues<2>& fv, CellB& b) const {
  b.n = fe.n_dofs_per_cell();
  b.nq = nq();
  b.rows.resize(std::size_t(b.n) * b.nq);
  for (unsigned q = 0; q < b.nq; ++q)
    for (unsigned i = 0; i < b.n; ++i) {
      const unsigned ci = fe.system_to_component_index(i).first;
      const auto g = fv.shape_grad(i, q);
      b.rows[q * b.n + i] = {{ci == 0 ? g[0] : 0.0, ci == 1 ? g[1] : 0.0, ci == 0 ? g[1] : g[0]}};
    }
  if (!pb.bbar) return;
  // monomials ξ^a ζ^c (a + c ≤ p − 1) in cell-scaled coordinates about the cell's centroid
  const unsigned deg = static_cast<unsigned>(std::max(1, pb.degree)) - 1;
  const auto& cell = fv.get_cell();
  const auto ctr = cell->center();
  const double h = cell->diameter();
  std::vector<std::pair<unsigned, unsigned>> mono;
  for (unsigned a = 0; a <= deg; ++a)
    for (unsigned c = 0; a + c <= deg; ++c) mono.emplace_back(a, c);
  const unsigned m = static_cast<unsigned>(mono.size());
  FullMatrix<double> P(b.nq, m), G(m, m), Ginv(m, m);
  for (unsigned q = 0; q < b.nq; ++q) {
    const auto x = fv.quadrature_point(q);
    const double xi = (x[0] - ctr[0]) / h, ze = (x[1] - ctr[1]) / h;
    for (unsigned k = 0; k < m; ++k)
      P(q, k) = std::pow(xi, mono[k].first) * std::pow(ze, mono[k].second);
  }
  for (unsigned k = 0; k < m; ++k)
    for (unsigned l = 0; l < m; ++l) {
      double s = 0;
      for (unsigned q = 0; q < b.nq; ++q) s += P(q, k) * P(q, l) * fv.JxW(q);
      G(k, l) = s;
    }
  Ginv.invert(G);
  // θ̄(q) = Σ_r proj[q·nq + r] θ(r), proj = P G⁻¹ Pᵀ W (L2 projection onto span{P_k} at the
  // quadrature points)
  std::vector<double> proj(std::size_t(b.nq) * b.nq, 0.0);
  for (unsigned q = 0; q < b.nq; ++q)
    for (unsigned r = 0; r < b.nq; ++r) {
      double s = 0;
      for (unsigned k = 0; k < m; ++k)
        for (unsigned l = 0; l < m; ++l) s += P(q, k) * Ginv(k, l) * P(r, l);
      proj[q * b.nq + r] = s * fv.JxW(r);
    }
  std::vector<double> div(b.nq);
  for (unsigned i = 0; i < b.n; ++i) {
    for (unsigned q = 0; q < b.nq; ++q) div[q] = b.rows[q * b.n + i][0] + b.rows[q * b.n + i][1];
    for (unsigned q = 0; q < b.nq; ++q) {
      double bar = 0;
      for (unsigned r = 0; r < b.nq; ++r) bar += proj[q * b.nq + r] * div[r];
      const double corr = 0.5 * (bar - div[q]);
      b.rows[q * b.n + i][0] += corr;
      b.rows[q * b.n + i][1] += corr;
    }
  }
}

void Core::cell_strain(const CellB& b, const dealii::Vector<double>& local,
                       std::vector<constitutive::Voigt>& eps) {
  eps.assign(b.nq, constitutive::Voigt{{0.0, 0.0, 0.0}});
  for (unsigned q = 0; q < b.nq; ++q)
    for (unsigned i = 0; i < b.n; ++i)
      for (int k = 0; k < 3; ++k) eps[q][k] += local[i] * b(i, q)[k];
}

void Implicit::assemble_mass_and_elastic() {
  FEValues<2> fv(core.mapping, core.fe, core.quad,
                 update_values | update_gradients | update_quadrature_points | update_JxW_values);
  const unsigned n = core.fe.n_dofs_per_cell();
  FullMatrix<double> cm(n, n), ck(n, n);
  std::vector<types::global_dof_index> ld(n);
  CellB cb;
  M = 0;
  K0 = 0;
  for (const auto& cell : core.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    fv.reinit(cell);
    cm = 0;
    ck = 0;
    const auto C = core.models[cell->material_id()].elastic_tangent();
    const double r = core.rho[cell->material_id()];
    core.cell_b(fv, cb);
    for (unsigned q = 0; q < core.nq(); ++q) {
      for (unsigned i = 0; i < n; ++i) {
        const unsigned ci = core.fe.system_to_component_index(i).first;
        const auto& Bi = cb(i, q);
        for (unsigned j = 0; j < n; ++j) {
          const unsigned cj = core.fe.system_to_component_index(j).first;
          if (ci == cj) cm(i, j) += r * fv.shape_value(i, q) * fv.shape_value(j, q) * fv.JxW(q);
          const auto& Bj = cb(j, q);
          double s = 0;
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) s += Bi[a] * C[a][b] * Bj[b];
          ck(i, j) += s * fv.JxW(q);
        }
      }
    }
    cell->get_dof_indices(ld);
    core.hom.distribute_local_to_global(cm, ld, M);
    core.hom.distribute_local_to_global(ck, ld, K0);
  }
  M.compress(VectorOperation::add);
  K0.compress(VectorOperation::add);
  // Lysmer & Kuhlemeyer (1969) viscous boundary: t = −ρ(c_p (v·n) n + c_s (v − (v·n) n)),
  // c_p = √((λ + 2G)/ρ), c_s = √(G/ρ) of the adjacent cell's elastic constants
  has_cabs = false;
  if (!core.pb.absorbing) return;
  has_cabs = true;
  Cabs.reinit(M);
  Cabs = 0;
  FEFaceValues<2> ffv(core.mapping, core.fe, core.face_quad,
                      update_values | update_normal_vectors | update_JxW_values);
  for (const auto& cell : core.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    cm = 0;
    bool any = false;
    for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f) {
      if (!cell->face(f)->at_boundary()) continue;
      const auto bid = cell->face(f)->boundary_id();
      if (bid > 3 || !core.pb.absorbing_sides[bid]) continue;
      any = true;
      ffv.reinit(cell, f);
      const constitutive::Hooke& P = core.models[cell->material_id()].elasticity().hooke;
      const double r = core.rho[cell->material_id()];
      const double G = P.shear_modulus(), lam = P.lame();
      const double cp = std::sqrt((lam + 2 * G) / r), cs = std::sqrt(G / r);
      for (unsigned q = 0; q < ffv.n_quadrature_points; ++q) {
        const auto nrm = ffv.normal_vector(q);
        for (unsigned i = 0; i < n; ++i) {
          const unsigned ci = core.fe.system_to_component_index(i).first;
          for (unsigned j = 0; j < n; ++j) {
            const unsigned cj = core.fe.system_to_component_index(j).first;
            // C_ij = ∫ N_i N_j ρ (c_p n_ci n_cj + c_s (δ_ci,cj − n_ci n_cj)) dΓ
            const double coef =
                r * (cp * nrm[ci] * nrm[cj] + cs * ((ci == cj ? 1.0 : 0.0) - nrm[ci] * nrm[cj]));
            cm(i, j) += ffv.shape_value(i, q) * ffv.shape_value(j, q) * coef * ffv.JxW(q);
          }
        }
      }
    }
    if (!any) continue;
    cell->get_dof_indices(ld);
    core.hom.distribute_local_to_global(cm, ld, Cabs);
  }
  Cabs.compress(VectorOperation::add);
}

void Core::region_force(std::size_t r, double x, double z, double& bx, double& bz) const {
  const Region& reg = pb.regions[r];
  const RegionGeom& g = geom[r + 1];
  const double Fx = reg.force_x(t), Fz = reg.force_z(t);
  const double Mt = reg.moment(t) + (reg.load_point.x - g.xc) * Fz - (reg.load_point.z - g.zc) * Fx;
  bx = Fx / g.area - Mt * (z - g.zc) / g.J;
  bz = Fz / g.area + Mt * (x - g.xc) / g.J;
}

std::string Implicit::return_counts() const {
  std::string s;
  for (std::size_t k = 0; k < returns.size(); ++k)
    if (returns[k] > 0)
      s += std::string(" ") + constitutive::kReturnNames[k] + "=" + std::to_string(returns[k]);
  return s;
}

void Implicit::assemble(bool matrix, const AffineConstraints<double>& cons, bool dynamic) {
  const Problem& pb = core.pb;
  core.update_ghost();
  FEValues<2> fv(core.mapping, core.fe, core.quad,
                 update_values | update_gradients | update_quadrature_points | update_JxW_values);
  FEFaceValues<2> ffv(core.mapping, core.fe, core.face_quad,
                      update_values | update_quadrature_points | update_normal_vectors |
                          update_JxW_values);
  const unsigned n = core.fe.n_dofs_per_cell();
  FullMatrix<double> ck(n, n);
  dealii::Vector<double> cr(n), cf(n), crhs(n);
  std::vector<types::global_dof_index> ld(n);
  std::vector<constitutive::Voigt> eps(core.nq());
  dealii::Vector<double> local(n);
  CellB cb;
  returns.fill(0);
  if (matrix) K = 0;
  rhs = 0;
  res = 0;
  f_internal = 0;
  const double shake = pb.shaking_component >= 0 && dynamic ? pb.shaking(core.t) : 0.0;
  for (const auto& cell : core.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    fv.reinit(cell);
    core.cell_b(fv, cb);
    cell->get_dof_values(core.u_ghost, local);
    core.cell_strain(cb, local, eps);
    ck = 0;
    cr = 0;
    cf = 0;
    const auto id = cell->material_id();
    const constitutive::Material& model = core.model_of(cell->active_cell_index(), id);
    const std::size_t base = cell->active_cell_index() * core.nq();
    for (unsigned q = 0; q < core.nq(); ++q) {
      const QpState& c0 = core.committed[base + q];
      QpState& s = core.trial[base + q];
      const constitutive::Voigt& e = eps[q];
      const constitutive::Voigt de{{e[0] - c0.eps[0], e[1] - c0.eps[1], e[2] - c0.eps[2]}};
      constitutive::VoigtMatrix tangent{};
      const constitutive::Return region =
          model.update(c0, de, s, matrix ? &tangent : nullptr, predictor_tangent);
      s.eps = e;
      ++returns[static_cast<std::size_t>(region)];
      // body force: gravity along −z, base shaking ρ·a(t) (soil), structure loads
      const auto xq = fv.quadrature_point(q);
      const bool weight = id == 0 || pb.regions[id - 1].dead_weight;
      double b[2] = {
          0.0, weight ? -core.rho[id] * pb.gravity * core.gfactor * core.weight_factor(id) : 0.0};
      // base shaking loads the soil only, as the DEM loads its particles only
      if (pb.shaking_component >= 0 && id == 0) b[pb.shaking_component] += core.rho[id] * shake;
      if (id > 0) {
        double bx = 0, bz = 0;
        core.region_force(id - 1, xq[0], xq[1], bx, bz);
        b[0] += bx * core.lambda;
        b[1] += bz * core.lambda;
      }
      const double w = fv.JxW(q);
      for (unsigned i = 0; i < n; ++i) {
        const unsigned ci = core.fe.system_to_component_index(i).first;
        const auto& Bi = cb(i, q);
        cf(i) += (Bi[0] * s.stress[0] + Bi[1] * s.stress[1] + Bi[2] * s.stress[2]) * w;
        cr(i) -= fv.shape_value(i, q) * b[ci] * w;
        if (!matrix) continue;
        double BiC[3] = {0, 0, 0};
        for (int a = 0; a < 3; ++a)
          for (int bb = 0; bb < 3; ++bb) BiC[bb] += Bi[a] * tangent[a][bb];
        for (unsigned j = 0; j < n; ++j) {
          const auto& Bj = cb(j, q);
          ck(i, j) += (BiC[0] * Bj[0] + BiC[1] * Bj[1] + BiC[2] * Bj[2]) * w;
        }
      }
    }
    // strip tractions: t = −p n on the selected boundary faces
    for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f)
      core.add_tractions(cell, f, ffv, [&](unsigned i, double fi) { cr(i) -= fi; });
    cell->get_dof_indices(ld);
    for (unsigned i = 0; i < n; ++i) {
      cr(i) += cf(i);
      crhs(i) = -cr(i);
    }
    res.add(ld, cr);
    f_internal.add(ld, cf);
    if (matrix)
      cons.distribute_local_to_global(ck, crhs, ld, K, rhs, true);
    else
      cons.distribute_local_to_global(crhs, ld, rhs);
  }
  // seating a contact body: its dead weight W = ρ A g on its master (seat_master; the nodes on
  // its faces follow the master, so the soil's reactions on them sum to W at equilibrium)
  for (std::size_t r = 0; r < core.seat_master.size(); ++r) {
    const types::global_dof_index i = core.seat_master[r];
    if (i == numbers::invalid_dof_index || !core.owned.is_element(i) || !pb.regions[r].dead_weight)
      continue;
    const auto id = static_cast<types::material_id>(r + 1);
    const double W =
        core.rho[id] * core.geom[id].area * pb.gravity * core.gfactor * core.weight_factor(id);
    const std::vector<types::global_dof_index> at{i};
    res.add(at, std::vector<double>{W}); // f_ext = (0, −W): res = f_int − f_ext
    dealii::Vector<double> load(1);
    load(0) = -W; // rhs = −res
    cons.distribute_local_to_global(load, at, rhs);
  }
  if (matrix) K.compress(VectorOperation::add);
  rhs.compress(VectorOperation::add);
  res.compress(VectorOperation::add);
  f_internal.compress(VectorOperation::add);
}

} // namespace demfem::continuum::fem
