// Mesh, degrees of freedom, materials and constraints of the plane-strain model (core.hpp).
#include "impl.hpp"

namespace demfem::continuum::fem {

// ---- MPI
// -----------------------------------------------------------------------------------------
struct MpiScope::Impl {
  std::unique_ptr<Utilities::MPI::MPI_InitFinalize> init;
};

MpiScope::MpiScope(int& argc, char**& argv) : impl_(std::make_unique<Impl>()) {
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (!initialised) impl_->init = std::make_unique<Utilities::MPI::MPI_InitFinalize>(argc, argv, 1);
}
MpiScope::~MpiScope() = default;
int MpiScope::rank() {
  return static_cast<int>(Utilities::MPI::this_mpi_process(MPI_COMM_WORLD));
}
int MpiScope::size() {
  return static_cast<int>(Utilities::MPI::n_mpi_processes(MPI_COMM_WORLD));
}
bool MpiScope::any(bool flag) {
  return Utilities::MPI::max(flag ? 1u : 0u, MPI_COMM_WORLD) != 0u;
}
bool MpiScope::same(long long value) {
  const auto v = static_cast<double>(value); // exact below 2^53
  return Utilities::MPI::max(v, MPI_COMM_WORLD) == Utilities::MPI::min(v, MPI_COMM_WORLD);
}

void ensure_mpi() {
  static int argc = 1;
  static char name[] = "demfem";
  static char* args[] = {name, nullptr};
  static char** argv = args;
  static MpiScope scope(argc, argv);
}

Core::Core(const Problem& p, bool mesh_only)
    : pb(p), fe(FE_Q<2>(static_cast<unsigned>(p.degree)), 2),
      quad(static_cast<unsigned>(p.degree) + 1), face_quad(static_cast<unsigned>(p.degree) + 1) {
  build_mesh();
  setup_dofs_and_materials();
  if (mesh_only) return;
  region_geometry();
  build_constraints();
  // every point stress-free, in its cell's model
  committed.assign(tria.n_active_cells() * nq(), QpState{});
  for (const auto& cell : tria.active_cell_iterators()) {
    QpState s;
    static_cast<constitutive::State&>(s) =
        model_of(cell->active_cell_index(), cell->material_id()).initial_state();
    std::fill_n(committed.begin() + std::ptrdiff_t(cell->active_cell_index() * nq()), nq(), s);
  }
  trial = committed;
}

Model::Impl::Impl(const Problem& p, bool mesh_only) : Core(p, mesh_only) {
  if (mesh_only) return;
  im.size();
  im.assemble_mass_and_elastic();
}

void Core::build_mesh() {
  const Mesh& m = pb.mesh;
  const std::size_t nx = m.dx.size(), nz = m.dz.size();
  Table<2, types::material_id> ids(nx, nz);
  double x = m.x0;
  for (std::size_t i = 0; i < nx; ++i) {
    double z = m.z0;
    for (std::size_t j = 0; j < nz; ++j) {
      const double xc = x + 0.5 * m.dx[i], zc = z + 0.5 * m.dz[j];
      types::material_id id = numbers::invalid_material_id;
      if (m.domain.empty() || inside(m.domain, xc, zc)) id = 0;
      for (std::size_t r = 0; r < pb.regions.size(); ++r)
        if (inside(pb.regions[r].outline, xc, zc))
          id = pb.regions[r].contact ? numbers::invalid_material_id // not meshed: a contact body
                                     : static_cast<types::material_id>(r + 1);
      ids[i][j] = id;
      z += m.dz[j];
    }
    x += m.dx[i];
  }
  GridGenerator::subdivided_hyper_rectangle(tria, {m.dx, m.dz}, dealii::Point<2>(m.x0, m.z0), ids,
                                            false);
  xmin = m.x0;
  zmin = m.z0;
  xmax = xmin;
  for (double d : m.dx) xmax += d;
  zmax = zmin;
  for (double d : m.dz) zmax += d;
  const double tol = 1e-9 * std::max(xmax - xmin, zmax - zmin);
  for (const auto& cell : tria.active_cell_iterators())
    for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f)
      if (cell->face(f)->at_boundary()) {
        const auto c = cell->face(f)->center();
        types::boundary_id b = 4;
        if (std::abs(c[0] - xmin) < tol)
          b = 0;
        else if (std::abs(c[0] - xmax) < tol)
          b = 1;
        else if (std::abs(c[1] - zmin) < tol)
          b = 2;
        else if (std::abs(c[1] - zmax) < tol)
          b = 3;
        cell->face(f)->set_boundary_id(b);
      }
  tria.refine_global(static_cast<unsigned>(std::max(0, m.refinement)));
}

void Core::setup_dofs_and_materials() {
  dof.reinit(tria);
  dof.distribute_dofs(fe);
  owned = dof.locally_owned_dofs();
  DoFTools::extract_locally_relevant_dofs(dof, relevant);

  // frictional interface: the soil cells sharing a face with a rigid region form a thin
  // Mohr–Coulomb layer of the interface's strength (one cell thick at the current refinement)
  iface_cell.assign(tria.n_active_cells(), 0);
  if (pb.interface_friction >= 0.0) {
    iface_model =
        constitutive::interface_layer(pb.soil, pb.interface_friction, pb.interface_cohesion);
    for (const auto& cell : tria.active_cell_iterators()) {
      if (cell->material_id() != 0) continue;
      for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f) {
        if (cell->face(f)->at_boundary()) continue;
        const auto id = cell->neighbor(f)->material_id();
        if (id > 0 && pb.regions[id - 1].rigid) iface_cell[cell->active_cell_index()] = 1;
      }
    }
  }
  // materials: the soil's model, the regions elastic
  models.assign(1, pb.soil);
  rho.assign(pb.regions.size() + 1, pb.density);
  for (std::size_t r = 0; r < pb.regions.size(); ++r) {
    models.emplace_back(constitutive::Elastic(pb.regions[r].material));
    rho[r + 1] = pb.regions[r].density;
  }
}

void Core::region_geometry() {
  // all cells: every rank holds the whole shared mesh
  geom.assign(pb.regions.size() + 1, RegionGeom{});
  {
    FEValues<2> fv(mapping, fe, quad, update_quadrature_points | update_JxW_values);
    for (const auto& cell : dof.active_cell_iterators()) {
      fv.reinit(cell);
      auto& g = geom[cell->material_id()];
      for (unsigned q = 0; q < nq(); ++q) {
        g.area += fv.JxW(q);
        g.xc += fv.quadrature_point(q)[0] * fv.JxW(q);
        g.zc += fv.quadrature_point(q)[1] * fv.JxW(q);
      }
    }
    for (auto& g : geom)
      if (g.area > 0) {
        g.xc /= g.area;
        g.zc /= g.area;
      }
    for (const auto& cell : dof.active_cell_iterators()) {
      fv.reinit(cell);
      auto& g = geom[cell->material_id()];
      for (unsigned q = 0; q < nq(); ++q) {
        const double rx = fv.quadrature_point(q)[0] - g.xc, rz = fv.quadrature_point(q)[1] - g.zc;
        g.J += (rx * rx + rz * rz) * fv.JxW(q);
      }
    }
    // unmeshed contact bodies (Region::contact): area, centroid and polar moment about the
    // centroid of the outline polygon (shoelace sums, e.g. Bourke 1988 "Calculating the area and
    // centroid of a polygon"; second moments ∫x² dA = Σ c_i (x_i² + x_i x_j + x_j²)/12)
    for (std::size_t r = 0; r < pb.regions.size(); ++r) {
      const auto& o = pb.regions[r].outline;
      if (!pb.regions[r].contact || o.size() < 3) continue;
      const double x0 = o[0].x, z0 = o[0].z; // relative coordinates (conditioning)
      double a = 0, sx = 0, sz = 0, ixx = 0, izz = 0;
      for (std::size_t i = 0; i < o.size(); ++i) {
        const auto& p = o[i];
        const auto& q = o[(i + 1) % o.size()];
        const double xi = p.x - x0, zi = p.z - z0, xj = q.x - x0, zj = q.z - z0;
        const double c = xi * zj - xj * zi;
        a += 0.5 * c;
        sx += (xi + xj) * c / 6.0;
        sz += (zi + zj) * c / 6.0;
        ixx += (xi * xi + xi * xj + xj * xj) * c / 12.0;
        izz += (zi * zi + zi * zj + zj * zj) * c / 12.0;
      }
      const double sgn = a < 0 ? -1.0 : 1.0; // clockwise outlines
      RegionGeom& g = geom[r + 1];
      g.area = sgn * a;
      g.xc = g.area > 0 ? sgn * sx / g.area : 0.0;
      g.zc = g.area > 0 ? sgn * sz / g.area : 0.0;
      g.J = sgn * (ixx + izz) - g.area * (g.xc * g.xc + g.zc * g.zc); // parallel axes
      g.xc += x0;
      g.zc += z0;
    }
  }
}

void Model::Impl::reconstrain() {
  // the same dofs and partition: the state vectors keep their values
  const Vec u_save(u), v_save(v);
  build_constraints();
  im.size();
  u = u_save;
  v = v_save;
  hom.distribute(u);
  hom.distribute(v);
  im.assemble_mass_and_elastic();
  dyn_init = false;
  ex.state.ready = false;
}

void Core::build_constraints() {
  // rigid regions: masters (2 dofs at the node nearest the pivot, 1 at the node farthest from
  // it along the better-conditioned direction) and slaves
  lines.clear();
  rigid.assign(pb.regions.size(), Rigid{});
  for (std::size_t r = 0; r < pb.regions.size(); ++r) {
    const Region& reg = pb.regions[r];
    if (!reg.rigid || reg.contact) continue;
    Rigid& R = rigid[r];
    R.is_dof.assign(dof.n_dofs(), 0);
    const auto& usp = fe.get_unit_support_points();
    std::vector<types::global_dof_index> ld(fe.n_dofs_per_cell());
    for (const auto& cell : dof.active_cell_iterators()) {
      if (cell->material_id() != r + 1) continue;
      cell->get_dof_indices(ld);
      for (unsigned i = 0; i < ld.size(); ++i)
        if (!R.is_dof[ld[i]]) {
          R.is_dof[ld[i]] = 1;
          R.dofs.push_back({ld[i],
                            {fe.system_to_component_index(i).first,
                             mapping.transform_unit_to_real_cell(cell, usp[i])}});
        }
    }
    if (R.dofs.empty())
      throw std::runtime_error("structure region '" + reg.name + "' has no cells");
    const double xp = reg.pivot.x, zp = reg.pivot.z;
    // A: nearest to the pivot (x and z dofs at the same support point)
    std::size_t ia = 0;
    double best = 1e300;
    for (std::size_t k = 0; k < R.dofs.size(); ++k) {
      const auto& P = R.dofs[k].second.second;
      const double d = std::hypot(P[0] - xp, P[1] - zp);
      if (R.dofs[k].second.first == 0 && d < best) {
        best = d;
        ia = k;
      }
    }
    const dealii::Point<2> A = R.dofs[ia].second.second;
    R.master[0] = R.dofs[ia].first;
    for (const auto& d : R.dofs)
      if (d.second.first == 1 && d.second.second.distance(A) < 1e-12 * (1 + A.norm()))
        R.master[1] = d.first;
    // B: maximise |det R| = |A_z − B_z| (x dof of B) or |B_x − A_x| (z dof of B)
    best = -1;
    std::size_t ib = 0;
    for (std::size_t k = 0; k < R.dofs.size(); ++k) {
      const auto& P = R.dofs[k].second.second;
      const double d = R.dofs[k].second.first == 0 ? std::abs(P[1] - A[1]) : std::abs(P[0] - A[0]);
      if (d > best) {
        best = d;
        ib = k;
      }
    }
    R.master[2] = R.dofs[ib].first;
    const unsigned cb = R.dofs[ib].second.first;
    const dealii::Point<2> B = R.dofs[ib].second.second;
    // m = S q with rows of the small rigid motion u = (ux − θ(z − zp), uz + θ(x − xp))
    auto row = [&](unsigned c, const dealii::Point<2>& P, double out[3]) {
      out[0] = c == 0 ? 1 : 0;
      out[1] = c == 1 ? 1 : 0;
      out[2] = c == 0 ? -(P[1] - zp) : (P[0] - xp);
    };
    double S[3][3];
    row(0, A, S[0]);
    row(1, A, S[1]);
    row(cb, B, S[2]);
    const double det = S[0][0] * (S[1][1] * S[2][2] - S[1][2] * S[2][1]) -
                       S[0][1] * (S[1][0] * S[2][2] - S[1][2] * S[2][0]) +
                       S[0][2] * (S[1][0] * S[2][1] - S[1][1] * S[2][0]);
    if (std::abs(det) < 1e-12)
      throw std::runtime_error("structure region '" + reg.name + "' is degenerate");
    for (int i = 0; i < 3; ++i) // inverse by cofactors
      for (int j = 0; j < 3; ++j) {
        const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
        R.T[i][j] = (S[i1][j1] * S[i2][j2] - S[i1][j2] * S[i2][j1]) / det;
      }
    // slaves: u_P = row(P) · T · m
    for (const auto& [i, cp] : R.dofs) {
      if (i == R.master[0] || i == R.master[1] || i == R.master[2]) continue;
      double rp[3];
      row(cp.first, cp.second, rp);
      Line l;
      for (int j = 0; j < 3; ++j) {
        const double c = rp[0] * R.T[0][j] + rp[1] * R.T[1][j] + rp[2] * R.T[2][j];
        if (std::abs(c) > 1e-14) l.entries.push_back({R.master[j], c});
      }
      lines[i] = std::move(l);
    }
    // fixed / prescribed components: rows T_k m = g_k(t), solved for |C| masters by
    // Gauss–Jordan elimination with column pivoting
    std::vector<std::array<double, 3>> A_;
    std::vector<std::array<double, 3>> W; // rhs weights on g = (g_x, g_z, g_θ)
    for (int k = 0; k < 3; ++k)
      if (reg.mode[k] != Region::Mode::Free) {
        A_.push_back(std::array<double, 3>{{R.T[k][0], R.T[k][1], R.T[k][2]}});
        std::array<double, 3> w{{0, 0, 0}};
        w[static_cast<std::size_t>(k)] = 1;
        W.push_back(w);
      }
    std::vector<int> pivcol(A_.size(), -1);
    std::vector<char> used(3, 0);
    for (std::size_t a = 0; a < A_.size(); ++a) {
      int pc = -1;
      for (int j = 0; j < 3; ++j)
        if (!used[j] && (pc < 0 || std::abs(A_[a][j]) > std::abs(A_[a][pc]))) pc = j;
      used[pc] = 1;
      pivcol[a] = pc;
      const double d = A_[a][pc];
      for (int j = 0; j < 3; ++j) {
        A_[a][j] /= d;
        W[a][j] /= d;
      }
      for (std::size_t b = 0; b < A_.size(); ++b) {
        if (b == a) continue;
        const double f = A_[b][pc];
        for (int j = 0; j < 3; ++j) {
          A_[b][j] -= f * A_[a][j];
          W[b][j] -= f * W[a][j];
        }
      }
    }
    for (std::size_t a = 0; a < A_.size(); ++a) {
      Line l;
      for (int j = 0; j < 3; ++j)
        if (j != pivcol[a] && !used[j] && std::abs(A_[a][j]) > 1e-14)
          l.entries.push_back({R.master[j], -A_[a][j]});
      const std::array<double, 3> w = W[a];
      l.target = [this, r, w]() {
        double g = 0;
        for (int k = 0; k < 3; ++k) {
          const Region& rg = pb.regions[r];
          if (rg.mode[k] == Region::Mode::Prescribed)
            g += w[static_cast<std::size_t>(k)] * rg.motion[k](t);
        }
        return g;
      };
      lines[R.master[pivcol[a]]] = std::move(l);
    }
    for (auto m_ : R.master) relevant.add_index(m_);
  }
  // a contact body being seated (seating_contact): the master, the z dof of the soil node on its
  // base (soil below: outward normal +z) nearest its pivot (ties: the lower dof index, so that
  // every rank picks the same one)
  seat_master.assign(pb.regions.size(), numbers::invalid_dof_index);
  if (std::find(seating_contact.begin(), seating_contact.end(), 1) != seating_contact.end()) {
    const auto nodes = contact_nodes();
    std::vector<double> best(pb.regions.size(), 1e300);
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const int reg = pb.contacts[k].region;
      if (reg < 0 || !seating_contact[static_cast<std::size_t>(reg)]) continue;
      const auto r = static_cast<std::size_t>(reg);
      for (const ContactNode& c : nodes[k]) {
        if (c.nz < 0.5) continue;
        const double d = std::hypot(c.X[0] - pb.regions[r].pivot.x, c.X[1] - pb.regions[r].pivot.z);
        if (d < best[r] - 1e-12 || (d <= best[r] + 1e-12 && c.iz < seat_master[r])) {
          best[r] = std::min(best[r], d);
          seat_master[r] = c.iz;
        }
      }
    }
    for (std::size_t r = 0; r < pb.regions.size(); ++r) {
      if (!seating_contact[r]) continue;
      if (seat_master[r] == numbers::invalid_dof_index)
        throw std::runtime_error("structure '" + pb.regions[r].name +
                                 "' in Coulomb contact cannot be seated: no soil below its base");
      relevant.add_index(seat_master[r]);
    }
  }
  relevant.compress();

  // constraints: rigid bodies, box boundary conditions, patches, pure-shear kinematics,
  // periodicity
  hom.clear();
  hom.reinit(relevant);
  for (const auto& [i, l] : lines) {
    if (!relevant.is_element(i)) continue;
    hom.add_line(i);
    hom.add_entries(i, l.entries);
  }
  auto in_rigid = [&](types::global_dof_index i) {
    for (const auto& R : rigid)
      if (!R.is_dof.empty() && R.is_dof[i]) return true;
    return false;
  };
  auto constrain = [&](types::global_dof_index i) {
    if (relevant.is_element(i) && !hom.is_constrained(i) && !in_rigid(i)) hom.add_line(i);
  };
  const double tol = 1e-7 * std::max(xmax - xmin, zmax - zmin);
  // faces on a Coulomb contact plane take no box boundary condition
  auto on_contact = [&](const dealii::Point<2>& c) {
    for (const ContactPlane& p : pb.contacts)
      if (on_segment(p.a, p.b, c[0], c[1], tol)) return true;
    return false;
  };
  const Bc bcs[4] = {pb.left, pb.right, pb.bottom, pb.top};
  for (types::boundary_id b = 0; b < 4; ++b) {
    if (bcs[b] == Bc::Free) continue;
    if (pb.mesh.periodic_x && b < 2) continue;
    const unsigned normal = b < 2 ? 0u : 1u;
    for (const auto& [i, cp] : face_dofs([&](const dealii::Point<2>&c, types::boundary_id id) {
           return id == b && !on_contact(c);
         }))
      if (bcs[b] == Bc::Fixed || cp.first == normal) constrain(i);
  }
  // Coulomb contact nodes (Problem::contacts) in the implicit stages (K0 state, seating): stuck
  // to their plane (μ_s > 0: both components held, the static Coulomb state while the shear
  // stays below μ_s σ_n) or on a roller (μ_s = 0: the normal component held); the explicit run
  // frees them and applies the contact forces
  contact_roller.assign(dof.n_dofs(), 0);
  const auto cnodes = contact_nodes();
  for (std::size_t k = 0; k < cnodes.size(); ++k)
    for (const ContactNode& c : cnodes[k]) {
      const bool normal_x = std::abs(c.nx) > 0.5;
      const bool stick = pb.contacts[k].mu_static > 0.0;
      const int reg = pb.contacts[k].region;
      const auto master =
          reg >= 0 ? seat_master[static_cast<std::size_t>(reg)] : numbers::invalid_dof_index;
      for (const auto i : {c.ix, c.iz}) {
        if (!stick && (i == c.ix) != normal_x) continue;
        if (master != numbers::invalid_dof_index && i == c.iz) {
          // seating a contact body: a node on its base moves down with it (u_z = u_z of the
          // master); one on a side face is on a roller (its z free): the sides take no friction
          // while it settles, so that every face meets Coulomb's law when the run starts (a stuck
          // side would hold up to ~1/4 of the weight at a shear/normal ratio above μ_s near the
          // surface, and slide off at the first step)
          if (std::abs(c.nz) > 0.5 && i != master && relevant.is_element(i) &&
              !hom.is_constrained(i) && !in_rigid(i)) {
            hom.add_line(i);
            hom.add_entry(i, master, 1.0);
            contact_roller[i] = 1;
          }
          continue;
        }
        if (relevant.is_element(i) && !hom.is_constrained(i) && !in_rigid(i)) {
          hom.add_line(i);
          contact_roller[i] = 1;
        }
      }
    }
  patch_dofs.clear();
  patch_target.clear();
  for (const Patch& p : pb.patches) {
    auto d = face_dofs([&](const dealii::Point<2>& c, types::boundary_id) {
      return on_segment(p.a, p.b, c[0], c[1], tol);
    });
    std::map<types::global_dof_index, std::pair<unsigned, dealii::Point<2>>> sel;
    for (const auto& [i, cp] : d) {
      if ((cp.first == 0 && !p.constrain_x) || (cp.first == 1 && !p.constrain_z)) continue;
      sel[i] = cp;
      const double rx = cp.second[0] - p.pivot.x, rz = cp.second[1] - p.pivot.z;
      // small rigid rotation: u = (ux − θ rz, uz + θ rx)
      patch_target[i] = cp.first == 0 ? p.ux - p.rotation * rz : p.uz + p.rotation * rx;
      if (relevant.is_element(i) && !in_rigid(i)) { // (may already be a box constraint)
        if (!hom.is_constrained(i)) hom.add_line(i);
        Line l;
        const double val = patch_target[i];
        l.target = [this, val]() { return lambda * val; };
        lines[i] = std::move(l);
      }
    }
    patch_dofs.push_back(std::move(sel));
  }
  if (pb.fix_z_everywhere) {
    std::vector<types::global_dof_index> ld(fe.n_dofs_per_cell());
    for (const auto& cell : dof.active_cell_iterators()) {
      if (cell->is_artificial()) continue;
      cell->get_dof_indices(ld);
      for (unsigned i = 0; i < ld.size(); ++i)
        if (fe.system_to_component_index(i).first == 1) constrain(ld[i]);
    }
  }
  if (pb.mesh.periodic_x) {
    // u(right, z) = u(left, z), component by component (single-rank construction)
    auto left = face_dofs([](const dealii::Point<2>&, types::boundary_id id) { return id == 0; });
    auto right = face_dofs([](const dealii::Point<2>&, types::boundary_id id) { return id == 1; });
    const double ptol = 1e-9 * (zmax - zmin);
    for (const auto& [r, rc] : right) {
      if (hom.is_constrained(r) || !relevant.is_element(r)) continue;
      for (const auto& [l, lc] : left)
        if (lc.first == rc.first && std::abs(lc.second[1] - rc.second[1]) < ptol) {
          hom.add_line(r);
          if (!hom.is_constrained(l)) hom.add_entry(r, l, 1.0);
          break;
        }
    }
  }
  hom.close();
  for (Vec* w : {&u, &v, &acc}) w->reinit(owned, comm);
  u_ghost.reinit(owned, relevant, comm);
}

std::vector<std::vector<Core::ContactNode>> Core::contact_nodes() const {
  std::vector<std::vector<ContactNode>> out(pb.contacts.size());
  if (pb.contacts.empty()) return out;
  const double tol = 1e-7 * std::max(xmax - xmin, zmax - zmin);
  const auto& usp = fe.get_unit_support_points();
  const unsigned n = fe.n_dofs_per_cell();
  std::vector<types::global_dof_index> ld(n);
  std::vector<std::map<types::global_dof_index, std::size_t>> seen(pb.contacts.size());
  FEFaceValues<2> ffv(mapping, fe, face_quad, update_values | update_JxW_values);
  for (const auto& cell : dof.active_cell_iterators()) {
    if (cell->is_artificial() || cell->material_id() != 0) continue;
    for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f) {
      if (!cell->face(f)->at_boundary()) continue;
      const auto fc = cell->face(f)->center();
      for (std::size_t k = 0; k < pb.contacts.size(); ++k) {
        const ContactPlane& p = pb.contacts[k];
        if (!on_segment(p.a, p.b, fc[0], fc[1], tol)) continue;
        // outward normal of the (axis-aligned) face: faces 0..3 = −x, +x, −z, +z
        const double nx = f == 0 ? -1 : f == 1 ? 1 : 0, nz = f == 2 ? -1 : f == 3 ? 1 : 0;
        cell->get_dof_indices(ld);
        ffv.reinit(cell, f);
        for (unsigned i = 0; i < n; ++i) {
          if (!fe.has_support_on_face(i, f) || fe.system_to_component_index(i).first != 0) continue;
          double w = 0;
          for (unsigned q = 0; q < ffv.n_quadrature_points; ++q)
            w += ffv.shape_value(i, q) * ffv.JxW(q);
          if (const auto it = seen[k].find(ld[i]); it != seen[k].end()) {
            out[k][it->second].weight += w;
            continue;
          }
          const unsigned node = fe.system_to_component_index(i).second;
          for (unsigned j = 0; j < n; ++j)
            if (fe.system_to_component_index(j).first == 1 &&
                fe.system_to_component_index(j).second == node) {
              seen[k][ld[i]] = out[k].size();
              out[k].push_back(
                  {ld[i], ld[j], mapping.transform_unit_to_real_cell(cell, usp[i]), nx, nz, w});
            }
        }
      }
    }
  }
  return out;
}

double Core::top_at(double x) const {
  const auto& poly = pb.mesh.domain;
  if (poly.empty()) return zmax;
  double top = zmin;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Point& a = poly[i];
    const Point& b = poly[j];
    if ((a.x <= x && b.x >= x) || (b.x <= x && a.x >= x)) {
      const double zz = std::abs(b.x - a.x) < 1e-300 ? std::max(a.z, b.z)
                                                     : a.z + (b.z - a.z) * (x - a.x) / (b.x - a.x);
      top = std::max(top, zz);
    }
  }
  return top;
}

Model::Model(const Problem& problem) : impl_(std::make_unique<Impl>(problem)) {}
Model::~Model() = default;

std::size_t Model::n_dofs() const {
  return impl_->dof.n_dofs();
}
std::size_t Model::n_cells() const {
  return impl_->tria.n_active_cells();
}
double Model::time() const {
  return impl_->t;
}
const std::string& Model::log() const {
  impl_->log_str = impl_->log.str();
  return impl_->log_str;
}

} // namespace demfem::continuum::fem
