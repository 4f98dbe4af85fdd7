// Observation: probes, reactions, soil pressures, energies, .vtu/.pvd output (either integrator).
#include "impl.hpp"

#include <algorithm>
#include <sstream>

#include "demfem/scene/write_file.hpp"

namespace demfem::continuum::fem {

namespace {
// value and gradient of the displacement-like field at a point; collective
template <class M> bool eval_at(const M& m, const Vec& field_ghost, Point p, double val[2]) {
  val[0] = val[1] = 0;
  double found = 0;
  try {
    const auto hit =
        GridTools::find_active_cell_around_point(m.mapping, m.dof, dealii::Point<2>(p.x, p.z));
    // a point off the mesh (e.g. inside an unmeshed contact body) gives an invalid iterator
    if (hit.first.state() == IteratorState::valid && hit.first->is_locally_owned()) {
      const Quadrature<2> q(GeometryInfo<2>::project_to_unit_cell(hit.second));
      FEValues<2> fv(m.mapping, m.fe, q, update_values);
      fv.reinit(hit.first);
      std::vector<dealii::Vector<double>> v(1, dealii::Vector<double>(2));
      fv.get_function_values(field_ghost, v);
      val[0] = v[0][0];
      val[1] = v[0][1];
      found = 1;
    }
  } catch (...) {
  }
  found = Utilities::MPI::sum(found, m.comm);
  val[0] = Utilities::MPI::sum(val[0], m.comm) / std::max(1.0, found);
  val[1] = Utilities::MPI::sum(val[1], m.comm) / std::max(1.0, found);
  return found > 0;
}
} // namespace

Point Model::displacement(Point p) const {
  impl_->update_ghost();
  double v[2];
  eval_at(*impl_, impl_->u_ghost, p, v);
  return {v[0], v[1]};
}

Point Model::velocity(Point p) const {
  Vec g(impl_->owned, impl_->relevant, impl_->comm);
  g = impl_->v;
  double v[2];
  eval_at(*impl_, g, p, v);
  return {v[0], v[1]};
}

Reaction Model::reaction(std::size_t patch) const {
  const Impl& m = *impl_;
  Reaction r;
  const Patch& p = m.pb.patches.at(patch);
  for (const auto& [i, cp] : m.patch_dofs.at(patch)) {
    if (!m.owned.is_element(i)) continue;
    const double f = m.im.res(i);
    if (cp.first == 0)
      r.fx += f;
    else
      r.fz += f;
    const double rx = cp.second[0] - p.pivot.x, rz = cp.second[1] - p.pivot.z;
    r.moment += cp.first == 0 ? -rz * f : rx * f;
  }
  r.fx = Utilities::MPI::sum(r.fx, m.comm);
  r.fz = Utilities::MPI::sum(r.fz, m.comm);
  r.moment = Utilities::MPI::sum(r.moment, m.comm);
  return r;
}

Reaction Model::soil_reaction(std::size_t region) const {
  Impl& m = *impl_;
  const Region& reg = m.pb.regions.at(region);
  if (reg.contact) { // a Coulomb contact body: the sum over its planes' contact forces
    Reaction out;
    for (std::size_t k = 0; k < m.pb.contacts.size(); ++k) {
      if (m.pb.contacts[k].region != static_cast<int>(region)) continue;
      const ContactForce c = contact_force(k);
      out.fx += c.fx;
      out.fz += c.fz;
      out.moment += c.moment;
    }
    return out;
  }
  const auto& R = m.rigid.at(region);
  m.update_ghost();
  Vec vg(m.owned, m.relevant, m.comm), ag(m.owned, m.relevant, m.comm);
  vg = m.v;
  ag = m.acc;
  const bool dyn = m.dyn_init;
  const double shake = m.pb.shaking_component >= 0 && dyn ? m.pb.shaking(m.t) : 0.0;
  FEValues<2> fv(m.mapping, m.fe, m.quad,
                 update_values | update_gradients | update_quadrature_points | update_JxW_values);
  const unsigned n = m.fe.n_dofs_per_cell();
  const auto& usp = m.fe.get_unit_support_points();
  std::vector<types::global_dof_index> ld(n);
  dealii::Vector<double> re(n);
  Impl::CellB cb;
  Reaction out;
  std::vector<char> is_reg;
  if (R.is_dof.empty()) { // elastic region: its cells' dofs
    is_reg.assign(m.dof.n_dofs(), 0);
    for (const auto& cell : m.dof.active_cell_iterators())
      if (cell->material_id() == region + 1) {
        cell->get_dof_indices(ld);
        for (auto i : ld) is_reg[i] = 1;
      }
  }
  const std::vector<char>& mark = R.is_dof.empty() ? is_reg : R.is_dof;
  for (const auto& cell : m.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned() || cell->material_id() != 0) continue;
    cell->get_dof_indices(ld);
    bool touches = false;
    for (auto i : ld) touches = touches || mark[i];
    if (!touches) continue;
    fv.reinit(cell);
    m.cell_b(fv, cb);
    re = 0;
    const double rho = m.rho[0];
    const constitutive::VoigtMatrix C = m.models[0].elastic_tangent();
    const std::size_t base = cell->active_cell_index() * m.nq();
    for (unsigned q = 0; q < m.nq(); ++q) {
      const QpState& st = m.committed[base + q];
      const double w = fv.JxW(q);
      double b[2] = {0.0, -rho * m.pb.gravity * m.gfactor};
      if (m.pb.shaking_component >= 0) b[m.pb.shaking_component] += rho * shake;
      // velocity, acceleration and elastic strain rate at q (inertia and Rayleigh damping)
      double vq[2] = {0, 0}, aq[2] = {0, 0}, ev[3] = {0, 0, 0};
      if (dyn)
        for (unsigned j = 0; j < n; ++j) {
          const unsigned cj = m.fe.system_to_component_index(j).first;
          vq[cj] += vg(ld[j]) * fv.shape_value(j, q);
          aq[cj] += ag(ld[j]) * fv.shape_value(j, q);
          for (int k = 0; k < 3; ++k) ev[k] += vg(ld[j]) * cb(j, q)[k];
        }
      double sv[3] = {0, 0, 0}; // β C ε̇ (stiffness-proportional Rayleigh damping stress)
      for (int a = 0; a < 3; ++a)
        for (int c = 0; c < 3; ++c) sv[a] += m.pb.rayleigh_beta * C[a][c] * ev[c];
      for (unsigned i = 0; i < n; ++i) {
        const unsigned ci = m.fe.system_to_component_index(i).first;
        const auto& Bi = cb(i, q);
        double r = 0;
        for (int a = 0; a < 3; ++a) r += Bi[a] * (st.stress[a] + sv[a]);
        // residual: internal − body + ρ(a + α v) (Newmark inertia, mass-proportional damping)
        r += fv.shape_value(i, q) * (-b[ci] + rho * (aq[ci] + m.pb.rayleigh_alpha * vq[ci]));
        re(i) += r * w;
      }
    }
    for (unsigned i = 0; i < n; ++i) {
      if (!mark[ld[i]]) continue;
      const unsigned ci = m.fe.system_to_component_index(i).first;
      const auto X = m.mapping.transform_unit_to_real_cell(cell, usp[i]);
      const double F = -re(i); // the soil cell pushes the region's node with −(its residual)
      const double rx = X[0] - reg.pivot.x, rz = X[1] - reg.pivot.z;
      if (ci == 0) {
        out.fx += F;
        out.moment -= rz * F; // (X − p) × F
      } else {
        out.fz += F;
        out.moment += rx * F;
      }
    }
  }
  out.fx = Utilities::MPI::sum(out.fx, m.comm);
  out.fz = Utilities::MPI::sum(out.fz, m.comm);
  out.moment = Utilities::MPI::sum(out.moment, m.comm);
  return out;
}

std::vector<double> Model::soil_pressure(std::size_t region, double z0, double z1, int bins,
                                         Reaction* force) const {
  const Impl& m = *impl_;
  const Region& reg = m.pb.regions.at(region);
  std::vector<double> p(static_cast<std::size_t>(std::max(bins, 1)), 0.0);
  const double h = (z1 - z0) / double(p.size());
  if (reg.contact) {
    // A Coulomb contact body: the normal contact forces N_i of each plane, as nodal pressures
    // p_i = N_i / ∫φ_i ds (row-sum lumped boundary mass: exact for a uniform pressure),
    // piecewise linear between the nodes along the plane, integrated over the z bins.
    if (force) *force = soil_reaction(region);
    const auto nodes = m.contact_nodes();
    for (std::size_t k = 0; k < m.pb.contacts.size(); ++k) {
      const ContactPlane& cp = m.pb.contacts[k];
      if (cp.region != static_cast<int>(region)) continue;
      const auto state = m.contact_state(k);
      std::vector<double> weight_of(m.dof.n_dofs(), 0.0);
      for (const auto& n : nodes[k]) weight_of[n.ix] = n.weight;
      const double ex = cp.b.x - cp.a.x, ez = cp.b.z - cp.a.z;
      std::vector<std::pair<double, std::pair<double, double>>> line; // (s, (z, p))
      for (const auto& c : state) {
        const double w = weight_of[c.ix];
        if (w <= 0) continue;
        line.push_back({(c.x - cp.a.x) * ex + (c.z - cp.a.z) * ez, {c.z, c.N / w}});
      }
      std::sort(line.begin(), line.end());
      const double len = std::hypot(ex, ez);
      for (std::size_t i = 0; i + 1 < line.size(); ++i) {
        const double ds = (line[i + 1].first - line[i].first) / len;
        const int sub = 16;
        for (int j = 0; j < sub; ++j) {
          const double f = (j + 0.5) / sub;
          const double z = (1 - f) * line[i].second.first + f * line[i + 1].second.first;
          const double pn = (1 - f) * line[i].second.second + f * line[i + 1].second.second;
          if (h > 0 && z >= z0 && z <= z1) {
            const auto bin = std::min(p.size() - 1, static_cast<std::size_t>((z - z0) / h));
            p[bin] += pn * ds / sub / h;
          }
        }
      }
    }
    return p;
  }
  Reaction F;
  FEValues<2> fv(m.mapping, m.fe, m.quad, update_quadrature_points);
  const unsigned n1 = static_cast<unsigned>(m.pb.degree) + 1; // Gauss points per direction
  for (const auto& cell : m.tria.active_cell_iterators()) {
    if (!cell->is_locally_owned() || cell->material_id() != 0) continue;
    for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f) {
      if (cell->face(f)->at_boundary() || cell->neighbor(f)->material_id() != region + 1) continue;
      fv.reinit(cell);
      // the soil stress interpolated (Lagrange, tensor product through the n1 × n1 Gauss points
      // of this axis-aligned cell, x index fastest) to points on the face
      const std::size_t base = cell->active_cell_index() * m.nq();
      std::vector<double> gx(n1), gz(n1);
      for (unsigned k = 0; k < n1; ++k) {
        gx[k] = fv.quadrature_point(k)[0];
        gz[k] = fv.quadrature_point(k * n1)[1];
      }
      auto lag = [&](const std::vector<double>& g, unsigned k, double x) {
        double l = 1;
        for (unsigned j = 0; j < n1; ++j)
          if (j != k) l *= (x - g[j]) / (g[k] - g[j]);
        return l;
      };
      const auto a = cell->face(f)->vertex(0), b = cell->face(f)->vertex(1);
      const double len = a.distance(b);
      // unit normal out of the soil cell (faces 0..3: −x, +x, −z, +z)
      const double nx = f == 0 ? -1 : f == 1 ? 1 : 0, nz = f == 2 ? -1 : f == 3 ? 1 : 0;
      const int sub = 16;
      for (int k = 0; k < sub; ++k) {
        const auto X = a + (b - a) * ((k + 0.5) / sub);
        double sig[3] = {0, 0, 0};
        for (unsigned iz = 0; iz < n1; ++iz)
          for (unsigned ix = 0; ix < n1; ++ix) {
            const double L = lag(gx, ix, X[0]) * lag(gz, iz, X[1]);
            const auto& st = m.committed[base + iz * n1 + ix].stress;
            for (int c = 0; c < 3; ++c) sig[c] += L * st[c];
          }
        const double ds = len / sub;
        // traction on the region (outward normal of the region = −n): t = σ(−n)
        const double tx = -(sig[0] * nx + sig[2] * nz), tz = -(sig[2] * nx + sig[1] * nz);
        F.fx += tx * ds;
        F.fz += tz * ds;
        F.moment += ((X[0] - reg.pivot.x) * tz - (X[1] - reg.pivot.z) * tx) * ds;
        const double pn = -(nx * (sig[0] * nx + sig[2] * nz) + nz * (sig[2] * nx + sig[1] * nz));
        if (h > 0 && X[1] >= z0 && X[1] <= z1) {
          const auto bin = std::min(p.size() - 1, static_cast<std::size_t>((X[1] - z0) / h));
          p[bin] += pn * ds / h;
        }
      }
    }
  }
  for (auto& v : p) v = Utilities::MPI::sum(v, m.comm);
  if (force) {
    force->fx = Utilities::MPI::sum(F.fx, m.comm);
    force->fz = Utilities::MPI::sum(F.fz, m.comm);
    force->moment = Utilities::MPI::sum(F.moment, m.comm);
  }
  return p;
}

Model::RegionMotion Model::region_motion(std::size_t region) const {
  Impl& m = *impl_;
  if (m.pb.regions.at(region).contact) { // unmeshed: its generalised coordinates (rest: zero)
    for (const auto& b : m.ex.state.bodies)
      if (b.contact && b.region == region) return RegionMotion{b.q[0], b.q[1], b.q[2]};
    return RegionMotion{};
  }
  m.update_ghost();
  if (!m.rigid.at(region).is_dof.empty()) {
    const auto& R = m.rigid[region];
    double q[3] = {0, 0, 0};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) q[i] += R.T[i][j] * m.u_ghost(R.master[j]);
    return RegionMotion{q[0], q[1], q[2]};
  }
  FEValues<2> fv(m.mapping, m.fe, m.quad, update_values | update_gradients | update_JxW_values);
  const FEValuesExtractors::Vector disp(0);
  std::vector<Tensor<1, 2>> val(m.nq());
  std::vector<Tensor<2, 2>> grad(m.nq());
  double a = 0, ux = 0, uz = 0, rot = 0;
  for (const auto& cell : m.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned() || cell->material_id() != region + 1) continue;
    fv.reinit(cell);
    fv[disp].get_function_values(m.u_ghost, val);
    fv[disp].get_function_gradients(m.u_ghost, grad);
    for (unsigned q = 0; q < m.nq(); ++q) {
      const double w = fv.JxW(q);
      a += w;
      ux += val[q][0] * w;
      uz += val[q][1] * w;
      rot += 0.5 * (grad[q][1][0] - grad[q][0][1]) * w; // ½ curl u = ½(∂uz/∂x − ∂ux/∂z)
    }
  }
  a = Utilities::MPI::sum(a, m.comm);
  RegionMotion r;
  if (a <= 0) return r;
  r.ux = Utilities::MPI::sum(ux, m.comm) / a;
  r.uz = Utilities::MPI::sum(uz, m.comm) / a;
  r.rotation = Utilities::MPI::sum(rot, m.comm) / a;
  return r;
}

double Model::elastic_energy() const {
  // cell by cell (constrained rows of the condensed matrices would add their artificial
  // diagonals): kinetic ½∫ρ|v|² (consistent mass; lumped ½Σ m_i v_i² with the explicit integrator)
  // plus elastic strain energy ½∫ ε̄ᵀ De ε̄ of the displacement (linear elastic problems)
  Impl& m = *impl_;
  m.update_ghost();
  Vec vg(m.owned, m.relevant, m.comm);
  vg = m.v;
  FEValues<2> fv(m.mapping, m.fe, m.quad,
                 update_values | update_gradients | update_quadrature_points | update_JxW_values);
  const unsigned n = m.fe.n_dofs_per_cell();
  dealii::Vector<double> lu(n), lv(n);
  std::vector<constitutive::Voigt> eps;
  Impl::CellB cb;
  double e = 0;
  const bool lumped = m.is_explicit() && m.ex.state.ready;
  for (const auto& cell : m.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    fv.reinit(cell);
    m.cell_b(fv, cb);
    cell->get_dof_values(m.u_ghost, lu);
    cell->get_dof_values(vg, lv);
    Impl::cell_strain(cb, lu, eps);
    const auto id = cell->material_id();
    const constitutive::VoigtMatrix C = m.models[id].elastic_tangent();
    for (unsigned q = 0; q < m.nq(); ++q) {
      const double w = fv.JxW(q);
      double vq[2] = {0, 0};
      for (unsigned i = 0; i < n; ++i)
        vq[m.fe.system_to_component_index(i).first] += lv[i] * fv.shape_value(i, q);
      if (!lumped) e += 0.5 * m.rho[id] * (vq[0] * vq[0] + vq[1] * vq[1]) * w;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) e += 0.5 * eps[q][a] * C[a][b] * eps[q][b] * w;
    }
  }
  if (lumped) // the replicated nodal vectors: each rank adds its owned dofs
    for (const auto i : m.owned)
      if (m.ex.state.kind[i] != 3)
        e += 0.5 * m.ex.state.mass[i] * m.ex.state.v[i] * m.ex.state.v[i];
  if (lumped) // moving contact bodies (unmeshed): ½ q̇ᵀ M_q q̇
    for (const auto& b : m.ex.state.bodies)
      if (b.contact)
        for (int a = 0; a < 3; ++a)
          for (int c = 0; c < 3; ++c) e += 0.5 * b.qv[a] * b.M[a][c] * b.qv[c];
  return Utilities::MPI::sum(e, m.comm);
}

std::vector<QpStress> Model::stresses() const {
  const Impl& m = *impl_;
  std::vector<QpStress> out;
  FEValues<2> fv(m.mapping, m.fe, m.quad, update_quadrature_points);
  for (const auto& cell : m.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    fv.reinit(cell);
    for (unsigned q = 0; q < m.nq(); ++q) {
      const QpState& s = m.committed[cell->active_cell_index() * m.nq() + q];
      out.push_back({fv.quadrature_point(q)[0], fv.quadrature_point(q)[1], s.stress[0], s.stress[1],
                     s.stress[2], s.syy, int(cell->material_id())});
    }
  }
  return out;
}

void Model::write_vtu(const std::string& directory, const std::string& basename, int index) {
  Impl& m = *impl_;
  m.update_ghost();
  Vec vg(m.owned, m.relevant, m.comm);
  vg = m.v;
  const std::size_t nc = m.tria.n_active_cells();
  std::vector<dealii::Vector<float>> cd(10, dealii::Vector<float>(nc));
  const char* names[10] = {"stress_xx",      "stress_zz",         "stress_xz", "stress_yy",
                           "plastic_strain", "volumetric_strain", "rotation",  "material",
                           "subdomain",      "young_modulus"};
  // The soil model's own point variables (void ratio, …), cell means over the soil's cells
  const std::vector<const char*> own =
      m.models.empty() ? std::vector<const char*>() : m.models.front().output_names();
  std::vector<dealii::Vector<float>> od(own.size(), dealii::Vector<float>(nc));
  std::vector<double> ov(own.size()), oacc(own.size());
  FEValues<2> fv(m.mapping, m.fe, m.quad, update_gradients | update_JxW_values);
  const FEValuesExtractors::Vector disp(0);
  std::vector<Tensor<2, 2>> grad(m.nq());
  for (const auto& cell : m.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    fv.reinit(cell);
    fv[disp].get_function_gradients(m.u_ghost, grad);
    const auto c = cell->active_cell_index();
    double a = 0;
    double acc[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    const constitutive::Material& model = m.model_of(c, cell->material_id());
    const bool soil = !own.empty() && cell->material_id() == 0 && !m.iface_cell[c];
    std::fill(oacc.begin(), oacc.end(), 0.0);
    for (unsigned q = 0; q < m.nq(); ++q) {
      const QpState& s = m.committed[c * m.nq() + q];
      const double w = fv.JxW(q);
      if (soil) {
        model.output(s, ov.data());
        for (std::size_t k = 0; k < own.size(); ++k) oacc[k] += ov[k] * w;
      }
      a += w;
      acc[0] += s.stress[0] * w;
      acc[1] += s.stress[1] * w;
      acc[2] += s.stress[2] * w;
      acc[3] += s.syy * w;
      acc[4] += model.equivalent_plastic_strain(s) * w; // √(2/3 εp:εp)
      acc[5] += (grad[q][0][0] + grad[q][1][1]) * w;
      acc[6] += 0.5 * (grad[q][1][0] - grad[q][0][1]) * w;
      acc[7] += s.stiffness * w; // × the material's E below (stress-dependent modulus)
    }
    for (int k = 0; k < 7; ++k) cd[k][c] = float(acc[k] / a);
    for (std::size_t k = 0; k < own.size(); ++k) od[k][c] = float(oacc[k] / a);
    cd[9][c] = float(model.elasticity().hooke.young * acc[7] / a);
    // material: 0 soil, k structure k, n_regions + 1 the interface layer
    cd[7][c] = m.iface_cell[c] ? float(m.pb.regions.size() + 1) : float(cell->material_id());
    cd[8][c] = float(cell->subdomain_id());
  }
  DataOut<2> out;
  out.attach_dof_handler(m.dof);
  std::vector<DataComponentInterpretation::DataComponentInterpretation> vec(
      2, DataComponentInterpretation::component_is_part_of_vector);
  out.add_data_vector(m.u_ghost, std::vector<std::string>(2, "displacement"),
                      DataOut<2>::type_dof_data, vec);
  out.add_data_vector(vg, std::vector<std::string>(2, "velocity"), DataOut<2>::type_dof_data, vec);
  for (int k = 0; k < 10; ++k) out.add_data_vector(cd[k], names[k], DataOut<2>::type_cell_data);
  for (std::size_t k = 0; k < own.size(); ++k)
    out.add_data_vector(od[k], own[k], DataOut<2>::type_cell_data);
  out.build_patches(m.mapping, static_cast<unsigned>(m.pb.degree));
  // The pieces "<basename>_<index>.<rank>.vtu" and the record "<basename>_<index>.pvtu" (the names
  // DataOut::write_vtu_with_pvtu_record gives), each through a checked atomic write.
  const unsigned rank = Utilities::MPI::this_mpi_process(m.comm);
  const unsigned ranks = Utilities::MPI::n_mpi_processes(m.comm);
  const std::string stem = basename + "_" + Utilities::int_to_string(unsigned(index), 4);
  const auto piece = [&](unsigned r) {
    return stem + "." + Utilities::int_to_string(r, Utilities::needed_digits(ranks - 1)) + ".vtu";
  };
  std::string failure;
  try {
    std::ostringstream vtu;
    out.write_vtu(vtu);
    scene::write_file_atomic(directory + "/" + piece(rank), vtu.str());
    if (rank == 0) {
      std::vector<std::string> pieces;
      for (unsigned r = 0; r < ranks; ++r) pieces.push_back(piece(r));
      std::ostringstream pvtu;
      out.write_pvtu_record(pvtu, pieces);
      scene::write_file_atomic(directory + "/" + stem + ".pvtu", pvtu.str());
    }
  } catch (const scene::WriteError& e) {
    failure = e.what();
  }
  if (MpiScope::any(!failure.empty()))
    throw scene::WriteError(failure.empty()
                                ? "cannot write " + directory + "/" + stem +
                                      ".pvtu: another MPI rank could not write its piece"
                                : failure);
  m.pvd_records.emplace_back(m.t, stem + ".pvtu");
}

void Model::write_pvd(const std::string& directory, const std::string& basename) const {
  std::string failure;
  if (Utilities::MPI::this_mpi_process(impl_->comm) == 0) {
    try {
      std::ostringstream pvd;
      DataOutBase::write_pvd_record(pvd, impl_->pvd_records);
      scene::write_file_atomic(directory + "/" + basename + ".pvd", pvd.str());
    } catch (const scene::WriteError& e) {
      failure = e.what();
    }
  }
  if (MpiScope::any(!failure.empty()))
    throw scene::WriteError(failure.empty() ? "cannot write " + directory + "/" + basename +
                                                  ".pvd (on the root rank)"
                                            : failure);
}

} // namespace demfem::continuum::fem
