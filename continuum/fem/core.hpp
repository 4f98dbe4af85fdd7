// Internal header of the deal.II/PETSc plane-strain solver: the pieces of a model that both
// integrators use (`Core`): the discretisation (mesh, dofs, quadrature, materials, B̄ rows), the
// constraints (rigid bodies, boundaries, patches, contact rollers), the loads (time, load factors,
// body forces, tractions), the quadrature points' states and the nodal fields. The integrators
// (implicit.hpp, explicit.hpp) own their own state and reach these through a `Core&`; Model::Impl
// (impl.hpp) composes the three. Only the solver's translation units include it (deal.II's flags,
// C++17):
//   mesh.cpp       mesh, dofs, materials, region geometry, constraints
//   assembly.cpp   B̄ rows, strains, body forces and tractions; the implicit system's matrices
//   implicit.cpp   Newton, static load stepping, Newmark-β, the K0 procedure
//   explicit.cpp   central differences (lumped mass, cell-wise internal force)
//   contact.cpp    Coulomb contact of the explicit integrator, contact forces
//   state.cpp      the explicit integrator's state as bytes (checkpoints) and back
//   output.cpp     observation: probes, reactions, pressures, energies, .vtu/.pvd
#pragma once

#include <limits>

#include "constitutive/registry.hpp"
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
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

namespace demfem::continuum::fem {

using namespace dealii;
using Vec = PETScWrappers::MPI::Vector;
using Mat = PETScWrappers::MPI::SparseMatrix;
using CellIterator = DoFHandler<2>::active_cell_iterator;

namespace detail {

inline bool inside(const std::vector<Point>& poly, double x, double z) {
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

inline bool on_segment(const Point& a, const Point& b, double x, double z, double tol) {
  const double ex = b.x - a.x, ez = b.z - a.z;
  const double len2 = ex * ex + ez * ez;
  const double t = len2 > 0 ? ((x - a.x) * ex + (z - a.z) * ez) / len2 : 0.0;
  if (t < -1e-9 || t > 1 + 1e-9) return false;
  const double px = a.x + t * ex - x, pz = a.z + t * ez - z;
  return std::sqrt(px * px + pz * pz) <= tol;
}

// A quadrature point: its constitutive state plus the total strain the state belongs to (the
// strain increment of the next update is measured from it).
struct QpState : constitutive::State {
  constitutive::Voigt eps{{0, 0, 0}}; // total strain (εxx, εzz, γxz)
};

} // namespace detail
using detail::inside;
using detail::on_segment;
using detail::QpState;

struct Core {
  Problem pb;
  MPI_Comm comm = MPI_COMM_WORLD;

  // ---- discretisation (mesh.cpp)
  parallel::shared::Triangulation<2> tria{MPI_COMM_WORLD};
  FESystem<2> fe;
  MappingQ<2> mapping{1};
  DoFHandler<2> dof{};
  QGauss<2> quad;
  QGauss<1> face_quad;
  IndexSet owned, relevant;
  double xmin = 0, xmax = 0, zmin = 0, zmax = 0;
  std::vector<char> iface_cell; // by active cell index: soil cell of the interface layer
  // constitutive models (constitutive/registry.hpp) by material id, and the interface layer's
  std::vector<constitutive::Material> models;
  constitutive::Material iface_model;
  [[nodiscard]] const constitutive::Material& model_of(unsigned cell_index,
                                                       types::material_id id) const {
    return iface_cell[cell_index] ? iface_model : models[id];
  }
  std::vector<double> rho; // density by material id
  struct RegionGeom {
    double area = 0, xc = 0, zc = 0, J = 0;
  };
  std::vector<RegionGeom> geom; // by material id

  // mesh_only: the mesh, dofs and materials, no constraints or state (what the explicit stable
  // step needs: fem::stable_time_step)
  explicit Core(const Problem& p, bool mesh_only = false);

  unsigned nq() const { return quad.size(); }
  // the tolerance of "a face lies on a segment" (tractions, patches, contact planes)
  [[nodiscard]] double segment_tolerance() const {
    return 1e-7 * std::max(xmax - xmin, zmax - zmin);
  }

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
  void cell_b(const FEValues<2>& fv, CellB& b) const;
  // ε̄ at every quadrature point of the cell from the nodal values `local` (Σ_i u_i B̄_i(q)).
  static void cell_strain(const CellB& b, const dealii::Vector<double>& local,
                          std::vector<constitutive::Voigt>& eps);

  void build_mesh();
  void setup_dofs_and_materials();
  void region_geometry(); // geom: area, centroid and polar moment of every material id

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
  // soil nodes on the boundary faces of a contact plane (Problem::contacts): (x dof, z dof,
  // support point, outward normal of the face) by plane
  struct ContactNode {
    types::global_dof_index ix, iz;
    dealii::Point<2> X;
    double nx, nz;
    double weight; // ∫φ_i ds over the node's faces on the plane
  };
  [[nodiscard]] std::vector<std::vector<ContactNode>> contact_nodes() const;
  double top_at(double x) const;

  // ---- constraints (mesh.cpp)
  AffineConstraints<double> hom; // homogeneous: rigid bodies, boundaries, patches, periodicity
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
  std::vector<Rigid> rigid;         // by region (empty is_dof for elastic regions)
  std::vector<char> contact_roller; // by dof: held by a contact plane in the implicit stages
  // Seating a structure in Coulomb contact (Region::seat with Region::contact; it has no dofs of
  // its own): while seating_contact[r] is set, build_constraints makes the z dof of the soil node
  // on its base nearest its pivot a master (seat_master[r]) that every other node on its base
  // follows vertically (stuck to the body translating downwards; x held, as in the K0 state; nodes
  // on its side faces on rollers), and assemble loads that master with the body's dead weight: one
  // static solve finds where the soil carries it. seat_master[r] is invalid otherwise.
  std::vector<char> seating_contact;
  std::vector<types::global_dof_index> seat_master;
  // rigid-body lines, box/patch/periodic constraints, the nodal fields sized
  void build_constraints();

  // ---- loads (assembly.cpp)
  double t = 0.0;
  // load factors: tractions/patches/structure loads, gravity, and the structures' own weight (0
  // during the K0 correction: the structures are released at t = 0)
  double lambda = 0.0, gfactor = 0.0, sfactor = 1.0;
  // while structures are seated: 1 for the regions being seated, the others weightless (their
  // weight acts from t = 0); empty otherwise
  std::vector<char> seating_mask;
  [[nodiscard]] double weight_factor(types::material_id id) const {
    if (id == 0) return 1.0;
    if (!seating_mask.empty() && !seating_mask[id - 1]) return 0.0;
    return sfactor;
  }
  // body force of region r at a point (resultant F at load_point plus moment M, distributed
  // linearly over the area: b = F/A + M_tot/J · e_z×r)
  void region_force(std::size_t r, double x, double z, double& bx, double& bz) const;
  // The tractions t = −p λ n (Problem::tractions, p > 0 pushing into the body) on face f of
  // `cell` when it lies on a traction's segment: add(i, ∫ N_i t_c(i) at one face quadrature point)
  // for every quadrature point and shape function of the cell, in that order (the one traction
  // assembly of both integrators).
  template <class Add>
  void add_tractions(const CellIterator& cell, unsigned f, FEFaceValues<2>& ffv, Add&& add) const {
    if (!cell->face(f)->at_boundary()) return;
    const double tol = segment_tolerance();
    const auto fc = cell->face(f)->center();
    for (const Traction& tr : pb.tractions) {
      if (!on_segment(tr.a, tr.b, fc[0], fc[1], tol)) continue;
      ffv.reinit(cell, f);
      for (unsigned q = 0; q < ffv.n_quadrature_points; ++q)
        for (unsigned i = 0; i < fe.n_dofs_per_cell(); ++i) {
          const unsigned ci = fe.system_to_component_index(i).first;
          add(i, ffv.shape_value(i, q) * (-tr.pressure * lambda * ffv.normal_vector(q)[ci]) *
                     ffv.JxW(q));
        }
    }
  }

  // ---- the quadrature points' states (one per point of every active cell)
  std::vector<QpState> committed, trial;
  void commit() { committed = trial; }
  // Each soil point's modulus factor from its current stress (a stress-dependent modulus of the
  // soil's model; no-op without one), its stress unchanged.
  void set_stiffness_from_stress();
  bool stiffness_set = false; // set_stiffness_from_stress has run

  // ---- nodal fields: displacement, velocity, acceleration (the explicit integrator copies its
  // own into them for observation), the ghosted displacement
  Vec u, v, acc;
  Vec u_ghost;
  void update_ghost() { u_ghost = u; }
  bool dyn_init = false; // the dynamics have started (initial acceleration set)
  bool is_explicit() const { return pb.integrator == "explicit"; }

  std::vector<Seating> seated; // initialise_gravity's seating stage (Region::seat)
  std::ostringstream log;
  std::string log_str;
  std::vector<std::pair<double, std::string>> pvd_records;

  template <class F> double sum(F f) const { return Utilities::MPI::sum(f(), comm); }
};

} // namespace demfem::continuum::fem
