// The deal.II/PETSc plane-strain solver (the only deal.II translation unit of the library).
#include "fem.hpp"

#include <deal.II/base/index_set.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/table.h>
#include <deal.II/base/utilities.h>
#include <deal.II/distributed/shared_tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/petsc_precondition.h>
#include <deal.II/lac/petsc_solver.h>
#include <deal.II/lac/petsc_sparse_matrix.h>
#include <deal.II/lac/petsc_vector.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/data_out.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

namespace demfem::continuum::fem {

using namespace dealii;
using Vec = PETScWrappers::MPI::Vector;
using Mat = PETScWrappers::MPI::SparseMatrix;

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

void ensure_mpi() {
  static int argc = 1;
  static char name[] = "demfem";
  static char* args[] = {name, nullptr};
  static char** argv = args;
  static MpiScope scope(argc, argv);
}

namespace {

bool inside(const std::vector<Point>& poly, double x, double z) {
  // even–odd rule (ray casting)
  bool in = false;
  const std::size_t n = poly.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Point& a = poly[i];
    const Point& b = poly[j];
    if ((a.z > z) != (b.z > z) && x < (b.x - a.x) * (z - a.z) / (b.z - a.z) + a.x) in = !in;
  }
  return in;
}

bool on_segment(const Point& a, const Point& b, double x, double z, double tol) {
  const double ex = b.x - a.x, ez = b.z - a.z;
  const double len2 = ex * ex + ez * ez;
  const double t = len2 > 0 ? ((x - a.x) * ex + (z - a.z) * ez) / len2 : 0.0;
  if (t < -1e-9 || t > 1 + 1e-9) return false;
  const double px = a.x + t * ex - x, pz = a.z + t * ez - z;
  return std::sqrt(px * px + pz * pz) <= tol;
}

struct QpState {
  mc::ElasticStrain ee;
  mc::Vec3 eps{{0, 0, 0}}; // total strain (εxx, εzz, γxz)
  mc::Vec3 stress{{0, 0, 0}};
  double syy = 0.0;
  double eps_p[4] = {0, 0, 0, 0}; // plastic strain xx, zz, γxz, yy
  bool plastic = false;           // the return of the last evaluation was plastic
};

} // namespace

// ---- the model
// -----------------------------------------------------------------------------------
struct Model::Impl {
  Problem pb;
  MPI_Comm comm = MPI_COMM_WORLD;
  parallel::shared::Triangulation<2> tria{MPI_COMM_WORLD};
  FESystem<2> fe;
  MappingQ<2> mapping{1};
  DoFHandler<2> dof{};
  QGauss<2> quad;
  QGauss<1> face_quad;
  IndexSet owned, relevant;
  AffineConstraints<double> hom, inh;
  std::map<types::global_dof_index, double> patch_target; // dof → value at load factor 1
  std::vector<std::map<types::global_dof_index, std::pair<unsigned, dealii::Point<2>>>> patch_dofs;
  // Constrained dofs whose value follows a target (patches, rigid-body masters): the raw
  // (unresolved) line; the Newton predictor gives them target − (u_i − Σ c_ij u_j).
  struct Line {
    std::vector<std::pair<types::global_dof_index, double>> entries;
    std::function<double()> target; // empty: 0 (slaves of a rigid body)
  };
  std::map<types::global_dof_index, Line> lines;
  struct Rigid {
    types::global_dof_index master[3] = {0, 0, 0};      // A_x, A_z, B_c
    double T[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}; // q = (ux, uz, θ) = T m
    std::vector<char> is_dof;                           // by global dof index
    std::vector<std::pair<types::global_dof_index, std::pair<unsigned, dealii::Point<2>>>> dofs;
  };
  std::vector<Rigid> rigid; // by region (empty is_dof for elastic regions)
  Mat K, M, K0, Cabs;
  bool has_cabs = false;
  Vec u, rhs, res, f_internal, du, v, acc, u_n, v_n, a_n;
  Vec u_ghost;
  std::vector<QpState> committed, trial;
  std::vector<mc::Parameters> mat; // by material id
  std::vector<char> iface_cell;    // by active cell index: soil cell of the interface layer
  mc::Parameters iface_mat;
  std::vector<double> rho;
  struct RegionGeom {
    double area = 0, xc = 0, zc = 0, J = 0;
  };
  std::vector<RegionGeom> geom;
  // load factors: tractions/patches/structure loads, gravity, and the structures' own weight (0
  // during the K0 correction: the structures are released at t = 0)
  double lambda = 0.0, gfactor = 0.0, sfactor = 1.0;
  double t = 0.0;
  bool dyn_init = false;
  double xmin = 0, xmax = 0, zmin = 0, zmax = 0;
  std::ostringstream log;
  std::string log_str;
  std::vector<std::pair<double, std::string>> pvd_records;

  explicit Impl(const Problem& p)
      : pb(p), fe(FE_Q<2>(static_cast<unsigned>(p.degree)), 2),
        quad(static_cast<unsigned>(p.degree) + 1), face_quad(static_cast<unsigned>(p.degree) + 1) {
    build_mesh();
    setup();
  }

  unsigned nq() const { return quad.size(); }

  // Strain–displacement rows B_i(q) = (εxx, εzz, γxz) of shape function i at quadrature point q
  // of the cell in `fv`, stored at [q·n + i]. With B-bar (Hughes 1980, "Generalization of
  // selective integration procedures to anisotropic and nonlinear media"), the in-plane
  // volumetric part θ_i = div φ_i is replaced by its L2 projection θ̄_i onto the polynomials of
  // total degree p − 1 on the cell (Q2/P1 for p = 2; the mean dilatation for p = 1), in the
  // plane-strain form ε̄ = ε + ½(θ̄ − θ)(1, 1, 0): the deviatoric part is kept, εyy stays 0.
  struct CellB {
    unsigned n = 0, nq = 0;
    std::vector<std::array<double, 3>> rows; // [q·n + i]
    [[nodiscard]] const std::array<double, 3>& operator()(unsigned i, unsigned q) const {
      return rows[q * n + i];
    }
  };
  void cell_b(const FEValues<2>& fv, CellB& b) const {
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
  // ε̄ at every quadrature point of the cell from the nodal values `local` (Σ_i u_i B̄_i(q)).
  static void cell_strain(const CellB& b, const dealii::Vector<double>& local,
                          std::vector<mc::Vec3>& eps) {
    eps.assign(b.nq, mc::Vec3{{0.0, 0.0, 0.0}});
    for (unsigned q = 0; q < b.nq; ++q)
      for (unsigned i = 0; i < b.n; ++i)
        for (int k = 0; k < 3; ++k) eps[q][k] += local[i] * b(i, q)[k];
  }

  void build_mesh() {
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
          if (inside(pb.regions[r].outline, xc, zc)) id = static_cast<types::material_id>(r + 1);
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

  // dofs on boundary faces selected by pred(face centre, boundary id) → (component, support point)
  template <class Pred>
  std::map<types::global_dof_index, std::pair<unsigned, dealii::Point<2>>> face_dofs(Pred pred) {
    std::map<types::global_dof_index, std::pair<unsigned, dealii::Point<2>>> out;
    const auto& usp = fe.get_unit_support_points();
    std::vector<types::global_dof_index> ld(fe.n_dofs_per_cell());
    for (const auto& cell : dof.active_cell_iterators()) {
      if (cell->is_artificial()) continue;
      for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f) {
        if (!cell->face(f)->at_boundary()) continue;
        if (!pred(cell->face(f)->center(), cell->face(f)->boundary_id())) continue;
        cell->get_dof_indices(ld);
        for (unsigned i = 0; i < fe.n_dofs_per_cell(); ++i)
          if (fe.has_support_on_face(i, f))
            out[ld[i]] = {fe.system_to_component_index(i).first,
                          mapping.transform_unit_to_real_cell(cell, usp[i])};
      }
    }
    return out;
  }

  void setup() {
    dof.reinit(tria);
    dof.distribute_dofs(fe);
    owned = dof.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(dof, relevant);

    // frictional interface: the soil cells sharing a face with a rigid region form a thin
    // Mohr–Coulomb layer of the interface's strength (one cell thick at the current refinement)
    iface_cell.assign(tria.n_active_cells(), 0);
    if (pb.interface_friction >= 0.0) {
      iface_mat = pb.soil;
      iface_mat.plastic = true;
      iface_mat.friction = pb.interface_friction;
      iface_mat.cohesion = pb.interface_cohesion;
      iface_mat.dilation = 0.0;
      iface_mat.tension_cutoff = pb.soil.plastic ? pb.soil.tension_cutoff : -1.0;
      for (const auto& cell : tria.active_cell_iterators()) {
        if (cell->material_id() != 0) continue;
        for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f) {
          if (cell->face(f)->at_boundary()) continue;
          const auto id = cell->neighbor(f)->material_id();
          if (id > 0 && pb.regions[id - 1].rigid) iface_cell[cell->active_cell_index()] = 1;
        }
      }
    }
    // materials
    mat.assign(pb.regions.size() + 1, pb.soil);
    rho.assign(pb.regions.size() + 1, pb.density);
    for (std::size_t r = 0; r < pb.regions.size(); ++r) {
      mat[r + 1] = pb.regions[r].material;
      mat[r + 1].plastic = false;
      rho[r + 1] = pb.regions[r].density;
    }
    // region geometry (all cells: every rank holds the whole shared mesh)
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
    }

    // rigid regions: masters (2 dofs at the node nearest the pivot, 1 at the node farthest from
    // it along the better-conditioned direction) and slaves
    lines.clear();
    rigid.assign(pb.regions.size(), Rigid{});
    for (std::size_t r = 0; r < pb.regions.size(); ++r) {
      const Region& reg = pb.regions[r];
      if (!reg.rigid) continue;
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
        const double d =
            R.dofs[k].second.first == 0 ? std::abs(P[1] - A[1]) : std::abs(P[0] - A[0]);
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
    const Bc bcs[4] = {pb.left, pb.right, pb.bottom, pb.top};
    for (types::boundary_id b = 0; b < 4; ++b) {
      if (bcs[b] == Bc::Free) continue;
      if (pb.mesh.periodic_x && b < 2) continue;
      const unsigned normal = b < 2 ? 0u : 1u;
      for (const auto& [i, cp] :
           face_dofs([b](const dealii::Point<2>&, types::boundary_id id) { return id == b; }))
        if (bcs[b] == Bc::Fixed || cp.first == normal) constrain(i);
    }
    const double tol = 1e-7 * std::max(xmax - xmin, zmax - zmin);
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
      auto right =
          face_dofs([](const dealii::Point<2>&, types::boundary_id id) { return id == 1; });
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

    DynamicSparsityPattern dsp(relevant);
    DoFTools::make_sparsity_pattern(dof, dsp, hom, false);
    SparsityTools::distribute_sparsity_pattern(dsp, owned, comm, relevant);
    K.reinit(owned, owned, dsp, comm);
    M.reinit(owned, owned, dsp, comm);
    K0.reinit(owned, owned, dsp, comm);
    for (Vec* w : {&u, &rhs, &res, &f_internal, &du, &v, &acc, &u_n, &v_n, &a_n})
      w->reinit(owned, comm);
    u_ghost.reinit(owned, relevant, comm);

    committed.assign(tria.n_active_cells() * nq(), QpState{});
    trial = committed;
    assemble_mass_and_elastic();
  }

  void update_ghost() { u_ghost = u; }

  // Consistent mass matrix and initial elastic stiffness (for Rayleigh damping).
  void assemble_mass_and_elastic() {
    FEValues<2> fv(mapping, fe, quad,
                   update_values | update_gradients | update_quadrature_points | update_JxW_values);
    const unsigned n = fe.n_dofs_per_cell();
    FullMatrix<double> cm(n, n), ck(n, n);
    std::vector<types::global_dof_index> ld(n);
    CellB cb;
    M = 0;
    K0 = 0;
    for (const auto& cell : dof.active_cell_iterators()) {
      if (!cell->is_locally_owned()) continue;
      fv.reinit(cell);
      cm = 0;
      ck = 0;
      const auto C = mc::elastic_tangent(mat[cell->material_id()]);
      const double r = rho[cell->material_id()];
      cell_b(fv, cb);
      for (unsigned q = 0; q < nq(); ++q) {
        for (unsigned i = 0; i < n; ++i) {
          const unsigned ci = fe.system_to_component_index(i).first;
          const auto& Bi = cb(i, q);
          for (unsigned j = 0; j < n; ++j) {
            const unsigned cj = fe.system_to_component_index(j).first;
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
      hom.distribute_local_to_global(cm, ld, M);
      hom.distribute_local_to_global(ck, ld, K0);
    }
    M.compress(VectorOperation::add);
    K0.compress(VectorOperation::add);
    // Lysmer & Kuhlemeyer (1969) viscous boundary: t = −ρ(c_p (v·n) n + c_s (v − (v·n) n)),
    // c_p = √((λ + 2G)/ρ), c_s = √(G/ρ) of the adjacent cell's elastic constants
    has_cabs = false;
    if (!pb.absorbing) return;
    has_cabs = true;
    Cabs.reinit(M);
    Cabs = 0;
    FEFaceValues<2> ffv(mapping, fe, face_quad,
                        update_values | update_normal_vectors | update_JxW_values);
    for (const auto& cell : dof.active_cell_iterators()) {
      if (!cell->is_locally_owned()) continue;
      cm = 0;
      bool any = false;
      for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f) {
        if (!cell->face(f)->at_boundary()) continue;
        const auto bid = cell->face(f)->boundary_id();
        if (bid > 3 || !pb.absorbing_sides[bid]) continue;
        any = true;
        ffv.reinit(cell, f);
        const mc::Parameters& P = mat[cell->material_id()];
        const double r = rho[cell->material_id()];
        const double G = P.young / (2 * (1 + P.poisson));
        const double lam = P.young * P.poisson / ((1 + P.poisson) * (1 - 2 * P.poisson));
        const double cp = std::sqrt((lam + 2 * G) / r), cs = std::sqrt(G / r);
        for (unsigned q = 0; q < ffv.n_quadrature_points; ++q) {
          const auto nrm = ffv.normal_vector(q);
          for (unsigned i = 0; i < n; ++i) {
            const unsigned ci = fe.system_to_component_index(i).first;
            for (unsigned j = 0; j < n; ++j) {
              const unsigned cj = fe.system_to_component_index(j).first;
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
      hom.distribute_local_to_global(cm, ld, Cabs);
    }
    Cabs.compress(VectorOperation::add);
  }

  // body force of region r at a point (resultant F at load_point plus moment M, distributed
  // linearly over the area: b = F/A + M_tot/J · e_z×r)
  void region_force(std::size_t r, double x, double z, double& bx, double& bz) const {
    const Region& reg = pb.regions[r];
    const RegionGeom& g = geom[r + 1];
    const double Fx = reg.force_x(t), Fz = reg.force_z(t);
    const double Mt =
        reg.moment(t) + (reg.load_point.x - g.xc) * Fz - (reg.load_point.z - g.zc) * Fx;
    bx = Fx / g.area - Mt * (z - g.zc) / g.J;
    bz = Fz / g.area + Mt * (x - g.xc) / g.J;
  }

  bool predictor_tangent = false; // first Newton iteration: yielding points keep a plastic tangent
  std::array<long, 9> returns{};  // quadrature points per mc::Return region in the last assembly
  [[nodiscard]] std::string return_counts() const {
    static const char* names[9] = {"el", "main",   "edgeL",  "edgeR", "apex",
                                   "t",  "t+main", "t+edge", "t+apex"};
    std::string s;
    for (std::size_t k = 0; k < returns.size(); ++k)
      if (returns[k] > 0) s += std::string(" ") + names[k] + "=" + std::to_string(returns[k]);
    return s;
  }

  // Residual (f_internal − fext, raw) and, if `matrix`, the tangent; the linear system (K, rhs =
  // −R) goes through `cons`. Trial states are updated.
  void assemble(bool matrix, const AffineConstraints<double>& cons, bool dynamic) {
    update_ghost();
    FEValues<2> fv(mapping, fe, quad,
                   update_values | update_gradients | update_quadrature_points | update_JxW_values);
    FEFaceValues<2> ffv(mapping, fe, face_quad,
                        update_values | update_quadrature_points | update_normal_vectors |
                            update_JxW_values);
    const unsigned n = fe.n_dofs_per_cell();
    FullMatrix<double> ck(n, n);
    dealii::Vector<double> cr(n), cf(n), crhs(n);
    std::vector<types::global_dof_index> ld(n);
    std::vector<mc::Vec3> eps(nq());
    dealii::Vector<double> local(n);
    CellB cb;
    returns.fill(0);
    if (matrix) K = 0;
    rhs = 0;
    res = 0;
    f_internal = 0;
    const double tol = 1e-7 * std::max(xmax - xmin, zmax - zmin);
    const double shake = pb.shaking_component >= 0 && dynamic ? pb.shaking(t) : 0.0;
    for (const auto& cell : dof.active_cell_iterators()) {
      if (!cell->is_locally_owned()) continue;
      fv.reinit(cell);
      cell_b(fv, cb);
      cell->get_dof_values(u_ghost, local);
      cell_strain(cb, local, eps);
      ck = 0;
      cr = 0;
      cf = 0;
      const auto id = cell->material_id();
      const mc::Parameters& P = iface_cell[cell->active_cell_index()] ? iface_mat : mat[id];
      const std::size_t base = cell->active_cell_index() * nq();
      for (unsigned q = 0; q < nq(); ++q) {
        const QpState& c0 = committed[base + q];
        QpState& s = trial[base + q];
        const mc::Vec3& e = eps[q];
        mc::ElasticStrain tr = c0.ee;
        for (int k = 0; k < 3; ++k) tr.in_plane[k] += e[k] - c0.eps[k];
        mc::Result r = mc::integrate(P, tr, predictor_tangent && c0.plastic);
        ++returns[static_cast<std::size_t>(r.region)];
        if (r.region == mc::Return::Apex || r.region == mc::Return::TensionApex) {
          // the consistent apex tangent is zero (perfect plasticity); a whole element at the apex
          // would make K singular, so 1e-4 of the elastic tangent is kept there (affects the
          // Newton rate only, never the converged stresses)
          const mc::Mat3 De = mc::elastic_tangent(P);
          for (int a = 0; a < 3; ++a)
            for (int bb = 0; bb < 3; ++bb) r.tangent[a][bb] = 1e-4 * De[a][bb];
        }
        s.ee = r.elastic;
        s.plastic = r.region != mc::Return::Elastic;
        s.eps = e;
        s.stress = r.stress;
        s.syy = r.stress_yy;
        for (int k = 0; k < 3; ++k)
          s.eps_p[k] =
              c0.eps_p[k] + (e[k] - c0.eps[k]) - (r.elastic.in_plane[k] - c0.ee.in_plane[k]);
        s.eps_p[3] = c0.eps_p[3] - (r.elastic.out_of_plane - c0.ee.out_of_plane);
        // body force: gravity along −z, base shaking ρ·a(t), structure loads
        const auto xq = fv.quadrature_point(q);
        const bool weight = id == 0 || pb.regions[id - 1].dead_weight;
        double b[2] = {0.0,
                       weight ? -rho[id] * pb.gravity * gfactor * (id > 0 ? sfactor : 1.0) : 0.0};
        if (pb.shaking_component >= 0) b[pb.shaking_component] += rho[id] * shake;
        if (id > 0) {
          double bx = 0, bz = 0;
          region_force(id - 1, xq[0], xq[1], bx, bz);
          b[0] += bx * lambda;
          b[1] += bz * lambda;
        }
        const double w = fv.JxW(q);
        for (unsigned i = 0; i < n; ++i) {
          const unsigned ci = fe.system_to_component_index(i).first;
          const auto& Bi = cb(i, q);
          cf(i) += (Bi[0] * r.stress[0] + Bi[1] * r.stress[1] + Bi[2] * r.stress[2]) * w;
          cr(i) -= fv.shape_value(i, q) * b[ci] * w;
          if (!matrix) continue;
          double BiC[3] = {0, 0, 0};
          for (int a = 0; a < 3; ++a)
            for (int bb = 0; bb < 3; ++bb) BiC[bb] += Bi[a] * r.tangent[a][bb];
          for (unsigned j = 0; j < n; ++j) {
            const auto& Bj = cb(j, q);
            ck(i, j) += (BiC[0] * Bj[0] + BiC[1] * Bj[1] + BiC[2] * Bj[2]) * w;
          }
        }
      }
      // strip tractions: t = −p n on the selected boundary faces
      for (unsigned f = 0; f < GeometryInfo<2>::faces_per_cell; ++f) {
        if (!cell->face(f)->at_boundary()) continue;
        const auto fc = cell->face(f)->center();
        for (const Traction& tr : pb.tractions) {
          if (!on_segment(tr.a, tr.b, fc[0], fc[1], tol)) continue;
          ffv.reinit(cell, f);
          for (unsigned q = 0; q < ffv.n_quadrature_points; ++q)
            for (unsigned i = 0; i < n; ++i) {
              const unsigned ci = fe.system_to_component_index(i).first;
              cr(i) -= ffv.shape_value(i, q) * (-tr.pressure * lambda * ffv.normal_vector(q)[ci]) *
                       ffv.JxW(q);
            }
        }
      }
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
    if (matrix) K.compress(VectorOperation::add);
    rhs.compress(VectorOperation::add);
    res.compress(VectorOperation::add);
    f_internal.compress(VectorOperation::add);
  }

  // Newmark constants (Newmark 1959): a = a0(u − u_n) − a2 v_n − a3 a_n, v = v_n + dt((1−γ)a_n +
  // γa)
  double dt_ = 0.0;
  void newmark_va(Vec& vel, Vec& accel) const {
    const double b = pb.newmark_beta, g = pb.newmark_gamma;
    accel = u;
    accel -= u_n;
    accel *= 1.0 / (b * dt_ * dt_);
    accel.add(-1.0 / (b * dt_), v_n);
    accel.add(-(1.0 / (2 * b) - 1.0), a_n);
    vel = v_n;
    vel.add(dt_ * (1 - g), a_n);
    vel.add(dt_ * g, accel);
  }

  // Add the inertia and Rayleigh damping forces M(a + αv) + βK0 v (C = αM + βK0, Rayleigh).
  void add_dynamic(bool matrix) {
    Vec vel(owned, comm), accel(owned, comm), tmp(owned, comm), tmp2(owned, comm);
    newmark_va(vel, accel);
    tmp = accel;
    tmp.add(pb.rayleigh_alpha, vel);
    M.vmult(tmp2, tmp);
    K0.vmult(tmp, vel);
    tmp2.add(pb.rayleigh_beta, tmp);
    if (has_cabs) {
      Cabs.vmult(tmp, vel);
      tmp2 += tmp;
    }
    res += tmp2;
    hom.set_zero(tmp2);
    rhs -= tmp2;
    if (matrix) {
      const double b = pb.newmark_beta, g = pb.newmark_gamma;
      const double a0 = 1.0 / (b * dt_ * dt_), a1 = g / (b * dt_);
      K.add(a0 + a1 * pb.rayleigh_alpha, M);
      K.add(a1 * pb.rayleigh_beta, K0);
      if (has_cabs) K.add(a1, Cabs);
    }
  }

  int solve_linear(bool symmetric) {
    // Krylov solves to 1e-8 of the Newton residual: enough for Newton to reach its tolerance
    // (an inexact Newton step, Eisenstat & Walker 1996), far cheaper than 1e-12
    SolverControl control(2000, std::max(1e-300, 1e-8 * rhs.l2_norm()));
    const std::string& s = pb.linear_solver;
    du = 0;
    if (s == "direct") {
      PETScWrappers::SparseDirectMUMPS solver(control, comm);
      solver.solve(K, du, rhs);
      return 1;
    }
    PETScWrappers::PreconditionBoomerAMG::AdditionalData data;
    data.symmetric_operator = symmetric && s == "cg-amg";
    data.strong_threshold = 0.5;
    PETScWrappers::PreconditionBoomerAMG amg(K, data);
    if (s == "cg-amg" && symmetric) {
      PETScWrappers::SolverCG solver(control, comm);
      solver.solve(K, du, rhs, amg);
    } else {
      // restart 100: the yielding backfill's non-symmetric tangent stalls GMRES(30)
      PETScWrappers::SolverGMRES solver(control, comm,
                                        PETScWrappers::SolverGMRES::AdditionalData(100));
      solver.solve(K, du, rhs, amg);
    }
    return static_cast<int>(control.last_step());
  }

  bool symmetric_tangent() const {
    return !pb.soil.plastic || std::abs(pb.soil.friction - pb.soil.dilation) < 1e-12;
  }

  double free_norm(const Vec& r) const {
    Vec tmp(r);
    hom.set_zero(tmp);
    return tmp.l2_norm();
  }

  static constexpr double stagnation_tolerance = 1e-5;
  static constexpr int max_nondescent = 3;
  // DEMFEM_NEWTON_TRACE=1: every step's Newton history (residual, return regions, line-search α)
  const bool trace_newton = std::getenv("DEMFEM_NEWTON_TRACE") != nullptr;
  const bool check_tangent = std::getenv("DEMFEM_TANGENT_CHECK") != nullptr;
  // Newton iteration to equilibrium at (lambda, gfactor) [and time t when dynamic].
  StepStats newton(bool dynamic) {
    StepStats st;
    // predictor: prescribed patch values through inhomogeneous constraints
    inh.clear();
    inh.reinit(relevant);
    update_ghost();
    for (types::global_dof_index i : relevant) {
      if (!hom.is_constrained(i)) continue;
      inh.add_line(i);
      auto it = lines.find(i);
      if (it == lines.end()) { // box/periodic: homogeneous, already resolved in hom
        const auto* entries = hom.get_constraint_entries(i);
        if (entries)
          for (const auto& e : *entries) inh.add_entry(i, e.first, e.second);
        continue;
      }
      // raw line (chains resolved by close()): du_i = Σ c du_j + target − (u_i − Σ c u_j)
      double g = it->second.target ? it->second.target() : 0.0;
      g -= u_ghost(i);
      for (const auto& e : it->second.entries) {
        inh.add_entry(i, e.first, e.second);
        g += e.second * u_ghost(e.first);
      }
      if (it->second.target) inh.set_inhomogeneity(i, g);
    }
    inh.close();
    const bool sym = symmetric_tangent();
    double ref = 0.0;
    int nondescent = 0;
    std::ostringstream trace;
    for (int it = 0; it <= pb.newton_max_iterations; ++it) {
      const AffineConstraints<double>& cons = it == 0 ? inh : hom;
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
        if (trace_newton)
          std::fprintf(stderr, "newton t=%g λ=%g\n%s\n", t, lambda, trace.str().c_str());
        return st;
      }
      if (it == pb.newton_max_iterations) break;
      try {
        st.linear_iterations += solve_linear(sym);
      } catch (const std::exception& e) { // e.g. the Krylov solver did not converge: cut the step
        log << "linear solver failed: " << std::string(e.what()).substr(0, 160) << "\n";
        break;
      }
      cons.distribute(du);
      if (!std::isfinite(du.l2_norm())) break;
      if (check_tangent && it > 0) { // directional derivative of R along du vs K du = −R
        const Vec u0(u), r0(rhs);
        double rel[3];
        int k = 0;
        auto rhs_at = [&](double s) { // rhs at u0 + s du
          u = u0;
          u.add(s, du);
          assemble(false, hom, dynamic);
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
        std::fprintf(stderr,
                     "tangent check t=%g λ=%g it=%d: |dR[du] + R|/|R| = %.3e %.3e %.3e (h = 1e-3, "
                     "1e-5, 1e-7 of the Newton step)\n",
                     t, lambda, it, rel[0], rel[1], rel[2]);
        u = u0;
        assemble(true, hom, dynamic);
        if (dynamic) add_dynamic(true);
      }
      // backtracking line search on the free residual norm
      const Vec u0(u);
      double alpha = 1.0, best = 0.0, best_alpha = 1.0;
      for (int ls = 0; ls < 4; ++ls) {
        u = u0;
        u.add(alpha, du);
        if (it == 0) break; // the predictor carries the prescribed jump: take it whole
        assemble(false, hom, dynamic);
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
        u = u0;
        if (rn <= stagnation_tolerance * ref) {
          assemble(false, hom, dynamic);
          if (dynamic) add_dynamic(false);
          log << "accepted stalled Newton at |R|/ref=" << rn / ref << "\n";
          st.converged = true;
          st.newton_iterations = it;
          return st;
        }
        // non-monotone escape: take the full Newton step anyway (a kink of the return map, not a
        // wrong direction, usually blocks descent); give up after `max_nondescent` such steps
        if (++nondescent > max_nondescent) break;
        u.add(1.0, du);
        trace << " α=1 (no descent)\n";
        continue;
      }
      if (it > 0 && alpha != best_alpha) {
        u = u0;
        u.add(best_alpha, du);
      }
      trace << " α=" << best_alpha << "\n";
    }
    log << "newton failed: λ=" << lambda << " g=" << gfactor << " structures' weight=" << sfactor
        << " t=" << t << " residual=" << st.residual << "\n"
        << trace.str();
    st.converged = false;
    st.newton_iterations = pb.newton_max_iterations;
    return st;
  }

  void commit() { committed = trial; }

  // statistics of a step taken as two halves a, b (b's convergence and residual)
  static StepStats halves(const StepStats& a, StepStats b) {
    b.cuts += a.cuts + 1;
    b.newton_iterations += a.newton_iterations;
    b.linear_iterations += a.linear_iterations;
    return b;
  }

  // static load stepping with step cutting
  StepStats static_to(double lam, double gf, int depth = 0, double sf = 1.0) {
    const Vec u_save(u);
    const double lam0 = lambda, gf0 = gfactor, sf0 = sfactor;
    lambda = lam;
    gfactor = gf;
    sfactor = sf;
    StepStats st = newton(false);
    if (st.converged) {
      commit();
      log << "static step λ=" << lam << " g=" << gf << " newton=" << st.newton_iterations
          << " linear=" << st.linear_iterations << " residual=" << st.residual << "\n";
      return st;
    }
    u = u_save;
    lambda = lam0;
    gfactor = gf0;
    sfactor = sf0;
    trial = committed;
    if (depth >= 8) return st;
    log << "step cut at λ=" << lam << "\n";
    StepStats a = static_to(0.5 * (lam0 + lam), 0.5 * (gf0 + gf), depth + 1, 0.5 * (sf0 + sf));
    if (!a.converged) return a;
    return halves(a, static_to(lam, gf, depth + 1, sf));
  }

  // One Newmark step of dt; on a Newton failure the step is undone and taken as two halves
  // (at most 5 levels deep).
  StepStats dynamic_to(double dt, int depth) {
    const Vec u0(u), v0(v), a0(a_n);
    const double t0 = t;
    dt_ = dt;
    u_n = u;
    v_n = v;
    lambda = 1.0;
    t += dt;
    // predictor u = u_n + dt v_n + dt²(½ − β) a_n (Newmark 1959)
    u.add(dt, v_n);
    u.add(dt * dt * (0.5 - pb.newmark_beta), a_n);
    StepStats st = newton(true);
    if (st.converged) {
      newmark_va(v, acc);
      a_n = acc;
      commit();
      return st;
    }
    u = u0;
    v = v0;
    a_n = a0;
    t = t0;
    trial = committed;
    if (depth >= 5) return st;
    log << "dynamic step cut at t=" << t0 << " dt=" << dt << "\n";
    StepStats a = dynamic_to(0.5 * dt, depth + 1);
    if (!a.converged) return a;
    return halves(a, dynamic_to(0.5 * dt, depth + 1));
  }

  double top_at(double x) const {
    const auto& poly = pb.mesh.domain;
    if (poly.empty()) return zmax;
    double top = zmin;
    for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
      const Point& a = poly[i];
      const Point& b = poly[j];
      if ((a.x <= x && b.x >= x) || (b.x <= x && a.x >= x)) {
        const double zz = std::abs(b.x - a.x) < 1e-300
                              ? std::max(a.z, b.z)
                              : a.z + (b.z - a.z) * (x - a.x) / (b.x - a.x);
        top = std::max(top, zz);
      }
    }
    return top;
  }

  template <class F> double sum(F f) const { return Utilities::MPI::sum(f(), comm); }
};

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
        s.stress = mc::Vec3{{k0 * szz, szz, 0.0}};
        s.syy = k0 * szz;
        s.ee = mc::elastic_strain_from_stress(m.mat[id], s.stress, s.syy);
      }
    }
    m.trial = m.committed;
    // the soil's weight balances the K0 stresses (up to the correction); the structures are
    // weightless here and their weight acts from the first dynamic step on, as in the DEM scenes,
    // where a structure is held while the bed is deposited and released at t = 0 (so settlements
    // include the settlement under the structure's own weight)
    m.gfactor = 1.0;
    m.sfactor = 0.0;
    total = m.static_to(m.lambda, 1.0, 0, 0.0);
    m.sfactor = 1.0;
  } else {
    steps = std::max(1, steps);
    for (int k = 1; k <= steps; ++k) {
      StepStats st = m.static_to(m.lambda, double(k) / steps);
      total.newton_iterations += st.newton_iterations;
      total.linear_iterations += st.linear_iterations;
      total.converged = st.converged;
      if (!st.converged) break;
    }
  }
  // displacements restart from zero; stresses stay
  m.u = 0;
  for (auto& s : m.committed) s.eps = mc::Vec3{{0, 0, 0}};
  m.trial = m.committed;
  return total;
}

StepStats Model::static_step(double lambda) {
  return impl_->static_to(lambda, impl_->gfactor);
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
  m.assemble(false, m.hom, false);
  m.commit();
}

StepStats Model::dynamic_step(double dt) {
  Impl& m = *impl_;
  if (!m.dyn_init) {
    // initial acceleration: M a0 = fext − f_internal(u0)
    m.assemble(false, m.hom, false);
    m.v_n = m.v;
    m.K = 0;
    m.K.add(1.0, m.M);
    m.rhs = m.res;
    m.rhs *= -1.0;
    m.hom.set_zero(m.rhs);
    m.solve_linear(true);
    m.hom.distribute(m.du);
    m.a_n = m.du;
    m.dyn_init = true;
  }
  return m.dynamic_to(dt, 0);
}

namespace {
// value and gradient of the displacement-like field at a point; collective
template <class M> bool eval_at(const M& m, const Vec& field_ghost, Point p, double val[2]) {
  val[0] = val[1] = 0;
  double found = 0;
  try {
    const auto hit =
        GridTools::find_active_cell_around_point(m.mapping, m.dof, dealii::Point<2>(p.x, p.z));
    if (hit.first->is_locally_owned()) {
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
    const double f = m.res(i);
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
    const mc::Parameters& P = m.mat[0];
    const double rho = m.rho[0];
    const mc::Mat3 C = mc::elastic_tangent(P);
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
  const Impl& m = *impl_;
  Vec tmp(m.owned, m.comm);
  m.M.vmult(tmp, m.v);
  double e = 0.5 * (tmp * m.v);
  m.K0.vmult(tmp, m.u);
  e += 0.5 * (tmp * m.u);
  return e;
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
  std::vector<dealii::Vector<float>> cd(9, dealii::Vector<float>(nc));
  const char* names[9] = {"stress_xx", "stress_zz",      "stress_xz",
                          "stress_yy", "plastic_strain", "volumetric_strain",
                          "rotation",  "material",       "subdomain"};
  FEValues<2> fv(m.mapping, m.fe, m.quad, update_gradients | update_JxW_values);
  const FEValuesExtractors::Vector disp(0);
  std::vector<Tensor<2, 2>> grad(m.nq());
  for (const auto& cell : m.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    fv.reinit(cell);
    fv[disp].get_function_gradients(m.u_ghost, grad);
    const auto c = cell->active_cell_index();
    double a = 0;
    double acc[7] = {0, 0, 0, 0, 0, 0, 0};
    for (unsigned q = 0; q < m.nq(); ++q) {
      const QpState& s = m.committed[c * m.nq() + q];
      const double w = fv.JxW(q);
      a += w;
      acc[0] += s.stress[0] * w;
      acc[1] += s.stress[1] * w;
      acc[2] += s.stress[2] * w;
      acc[3] += s.syy * w;
      // equivalent plastic strain √(2/3 εp:εp)
      const double e2 = s.eps_p[0] * s.eps_p[0] + s.eps_p[1] * s.eps_p[1] +
                        s.eps_p[3] * s.eps_p[3] + 0.5 * s.eps_p[2] * s.eps_p[2];
      acc[4] += std::sqrt(2.0 / 3.0 * e2) * w;
      acc[5] += (grad[q][0][0] + grad[q][1][1]) * w;
      acc[6] += 0.5 * (grad[q][1][0] - grad[q][0][1]) * w;
    }
    for (int k = 0; k < 7; ++k) cd[k][c] = float(acc[k] / a);
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
  for (int k = 0; k < 9; ++k) out.add_data_vector(cd[k], names[k], DataOut<2>::type_cell_data);
  out.build_patches(m.mapping, static_cast<unsigned>(m.pb.degree));
  const std::string name = out.write_vtu_with_pvtu_record(directory + "/", basename,
                                                          static_cast<unsigned>(index), m.comm, 4);
  m.pvd_records.emplace_back(m.t, name);
}

void Model::write_pvd(const std::string& directory, const std::string& basename) const {
  if (Utilities::MPI::this_mpi_process(impl_->comm) != 0) return;
  std::ofstream f(directory + "/" + basename + ".pvd");
  DataOutBase::write_pvd_record(f, impl_->pvd_records);
}

} // namespace demfem::continuum::fem
