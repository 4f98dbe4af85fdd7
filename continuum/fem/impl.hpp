// Internal header of the deal.II/PETSc plane-strain solver: the model's state (`Model::Impl`)
// shared by its translation units:
//   fem_mesh.cpp      mesh, dofs, constraints (rigid bodies, boundaries, patches), setup
//   fem_assembly.cpp  B-bar strain rows, mass/stiffness matrices, residual and tangent assembly
//   fem_implicit.cpp  Newton, static load stepping, Newmark-β, the K0 procedure
//   fem_explicit.cpp  central-difference integration (lumped mass, cell-wise internal force)
//   fem_output.cpp    observation: probes, reactions, pressures, energies, .vtu/.pvd
// Only these files include it (deal.II's flags, C++17).
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

// ---- the model
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
  // prescribed_rates: the constraints giving the constrained dofs' velocity and acceleration at
  // time rate_t (rebuilt when the time changes)
  AffineConstraints<double> rate_v, rate_a;
  double rate_t = std::numeric_limits<double>::quiet_NaN(), rate_dt = 0.0;
  struct Rigid {
    types::global_dof_index master[3] = {0, 0, 0};      // A_x, A_z, B_c
    double T[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}; // q = (ux, uz, θ) = T m
    std::vector<char> is_dof;                           // by global dof index
    std::vector<std::pair<types::global_dof_index, std::pair<unsigned, dealii::Point<2>>>> dofs;
  };
  std::vector<Rigid> rigid;         // by region (empty is_dof for elastic regions)
  std::vector<char> contact_roller; // by dof: held by a contact plane in the implicit stages
  Mat K, M, K0, Cabs;
  bool has_cabs = false;
  Vec u, rhs, res, f_internal, du, v, acc, u_n, v_n, a_n;
  Vec u_ghost;
  std::vector<QpState> committed, trial;
  std::vector<char> iface_cell; // by active cell index: soil cell of the interface layer
  // constitutive models (constitutive/registry.hpp) by material id, and the interface layer's
  std::vector<constitutive::Material> models;
  constitutive::Material iface_model;
  [[nodiscard]] const constitutive::Material& model_of(unsigned cell_index,
                                                       types::material_id id) const {
    return iface_cell[cell_index] ? iface_model : models[id];
  }
  std::vector<double> rho;
  struct RegionGeom {
    double area = 0, xc = 0, zc = 0, J = 0;
  };
  std::vector<RegionGeom> geom;
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
  double t = 0.0;
  bool dyn_init = false;
  double xmin = 0, xmax = 0, zmin = 0, zmax = 0;
  std::ostringstream log;
  std::string log_str;
  std::vector<std::pair<double, std::string>> pvd_records;

  // mesh_only: the mesh, dofs and materials, no constraints, matrices or state (what the
  // explicit stable step needs: fem::stable_time_step)
  explicit Impl(const Problem& p, bool mesh_only = false);

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
  void cell_b(const FEValues<2>& fv, CellB& b) const;
  // ε̄ at every quadrature point of the cell from the nodal values `local` (Σ_i u_i B̄_i(q)).
  static void cell_strain(const CellB& b, const dealii::Vector<double>& local,
                          std::vector<constitutive::Voigt>& eps);

  void build_mesh();

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

  void setup_dofs_and_materials();
  void setup(); // constraints, geometry, state, matrices (after setup_dofs_and_materials)
  // rigid-body lines, box/patch/periodic constraints, sparsity, matrices and vectors (sized)
  void build_constraints();
  // the constraints again after a region's DoF modes changed (structure seating): u and v keep
  // their values, M/K0 are reassembled, the dynamic and explicit initialisations start over
  void reconstrain();
  std::vector<Seating> seated; // initialise_gravity's seating stage (Region::seat)
  // Seating a structure in Coulomb contact (Region::seat with Region::contact; it has no dofs of
  // its own): while seating_contact[r] is set, build_constraints makes the z dof of the soil node
  // on its base nearest its pivot a master (seat_master[r]) that every other node on its base
  // follows vertically (stuck to the body translating downwards; x held, as in the K0 state; nodes
  // on its side faces on rollers), and assemble loads that master with the body's dead weight: one
  // static solve finds where the soil carries it. seat_master[r] is invalid otherwise.
  std::vector<char> seating_contact;
  std::vector<types::global_dof_index> seat_master;

  void update_ghost() { u_ghost = u; }

  // Consistent mass matrix and initial elastic stiffness (for Rayleigh damping).
  void assemble_mass_and_elastic();

  // body force of region r at a point (resultant F at load_point plus moment M, distributed
  // linearly over the area: b = F/A + M_tot/J · e_z×r)
  void region_force(std::size_t r, double x, double z, double& bx, double& bz) const;

  bool predictor_tangent = false; // first Newton iteration: yielding points keep a plastic tangent
  // quadrature points per constitutive::Return region in the last assembly
  std::array<long, constitutive::kReturnNames.size()> returns{};
  [[nodiscard]] std::string return_counts() const;

  // Residual (f_internal − fext, raw) and, if `matrix`, the tangent; the linear system (K, rhs =
  // −R) goes through `cons`. Trial states are updated.
  void assemble(bool matrix, const AffineConstraints<double>& cons, bool dynamic);

  // Newmark constants (Newmark 1959): a = a0(u − u_n) − a2 v_n − a3 a_n, v = v_n + dt((1−γ)a_n +
  // γa)
  double dt_ = 0.0;
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

  static constexpr double stagnation_tolerance = 1e-5;
  static constexpr int max_nondescent = 3;
  // Newton iteration to equilibrium at (lambda, gfactor) [and time t when dynamic].
  StepStats newton(bool dynamic);

  void commit() { committed = trial; }

  // statistics of a step taken as two halves a, b (b's convergence and residual)
  static StepStats halves(const StepStats& a, StepStats b);

  // static load stepping with step cutting
  StepStats static_to(double lam, double gf, int depth = 0, double sf = 1.0);

  // One Newmark step of dt; on a Newton failure the step is undone and taken as two halves
  // (at most 5 levels deep).
  StepStats dynamic_to(double dt, int depth);

  double top_at(double x) const;

  // ---- explicit central differences (fem_explicit.cpp)
  struct Explicit {
    bool ready = false;
    double omega_max = 0.0; // element bound on the highest angular frequency [rad/s]
    double dt_stable = 0.0; // safety × critical step
    unsigned n = 0, nq = 0; // dofs and quadrature points per cell
    // replicated full-length nodal vectors (the same on every rank); f_int: the internal force,
    // each rank's cells summed over the ranks
    std::vector<double> u, v, a, f, f_int, mass, damp;
    std::vector<double> f_static, f_shake; // gravity + tractions; shaking per unit acceleration
    std::vector<std::array<std::vector<double>, 3>> f_region; // per region: unit Fx, Fz, Mt
    // cells with stresses (every non-rigid cell owned by this rank): dofs, B̄ rows, weights, state
    // offset, model
    std::vector<types::global_dof_index> cell_dofs; // [c·n + i]
    std::vector<double> cell_B;                     // [((c·nq + q)·n + i)·3 + k]
    std::vector<double> cell_w;                     // [c·nq + q]
    std::vector<std::size_t> cell_base;             // state index of the cell's first point
    std::vector<const constitutive::Material*> cell_model;
    std::vector<constitutive::VoigtMatrix>
        cell_De; // elastic tangent (stiffness-proportional damping)
    // dof classes: 0 free, 1 fixed (zero), 2 prescribed (patch target), 3 follows a master
    // (periodic), 4 rigid body
    std::vector<char> kind;
    std::vector<std::pair<types::global_dof_index, types::global_dof_index>> follows;
    std::vector<std::pair<types::global_dof_index, double>> prescribed;
    struct Body {
      std::size_t region = 0;
      std::vector<types::global_dof_index> dofs;
      std::vector<std::array<double, 3>> rows; // u_i = rows_i · q
      double M[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
      double q[3] = {0, 0, 0}, qv[3] = {0, 0, 0}, qa[3] = {0, 0, 0};
      double q_prev[3] = {0, 0, 0}; // prescribed components one step back
      // A moving structure in Coulomb contact (Region::contact with a DoF not fixed): not
      // meshed (no dofs/rows); M from its outline × density, its dead weight as a generalised
      // force Qw, its soil contacts (indices into `contacts`) solved with it
      // (explicit_contact_body)
      bool contact = false;
      double Qw[3] = {0, 0, 0};
      std::vector<std::size_t> contacts;
      long passes = 0, unsettled = 0; // active-set passes; steps that ended unsettled
    };
    std::vector<Body> bodies;
    // Coulomb contact nodes (Problem::contacts): one per (node, plane); n the soil's outward
    // normal (into the plane), t = (−n_z, n_x); the last contact force on the soil (fx, fz) and
    // its normal (N ≥ 0) and tangential parts
    struct Contact {
      types::global_dof_index ix = 0, iz = 0;
      double nx = 0, nz = 0, x = 0, z = 0;
      std::size_t plane = 0;
      double fx = 0, fz = 0, N = 0, Ft = 0;
      bool slide = false;
      // held by another constraint (a fixed dof of a box side off the planes, e.g. the corner
      // with a fixed base): no contact law; its reaction's normal component is reported
      bool held = false;
      // ≥ 0: the soil node touches a face of the moving contact body bodies[body]: gap and
      // relative velocity are measured against the body's surface motion (J q at (x, z)); the
      // active-set state of its last step (0 open, 1 stick, 2 slide) and the slip direction
      int body = -1;
      int status = 1;
      double sign = 0.0;
    };
    std::vector<Contact> contacts;
    std::vector<double> contact_work; // by plane: work of the contact forces on the soil [J/m]
    // the step the contact forces look ahead over (Δt) and the time to the next velocity (τ: Δt,
    // or Δt/2 at the initial acceleration)
    double contact_dt = 0.0, contact_tau = 0.0;
    long steps = 0;
    // wall time of the steps: total, the cell loop and the reduction (Model::explicit_profile)
    double step_s = 0.0, cells_s = 0.0, reduce_s = 0.0;
  } ex;
  bool is_explicit() const { return pb.integrator == "explicit"; }
  void explicit_setup();
  double explicit_stable_step();
  // Each soil point's modulus factor from its current stress (a stress-dependent modulus of the
  // soil's model; no-op without one), its stress unchanged.
  void set_stiffness_from_stress();
  bool stiffness_set = false;     // set_stiffness_from_stress has run
  void explicit_accel(double dt); // a from u, v at time t (dt: the step, for prescribed motion)
  void explicit_gather_classes(); // several ranks: the dof classes of every rank's owned dofs
  void explicit_contact_setup();  // contact nodes of Problem::contacts (after the dof classes)
  void explicit_contacts();       // contact forces into a (after the free accelerations)
  // a moving contact body's acceleration and its soil contacts' forces, solved together
  void explicit_contact_body(Explicit::Body& b, double dt);
  // soil nodes on the boundary faces of a contact plane: (x dof, z dof, support point, outward
  // normal of the face) by plane
  struct ContactNode {
    types::global_dof_index ix, iz;
    dealii::Point<2> X;
    double nx, nz;
    double weight; // ∫φ_i ds over the node's faces on the plane
  };
  [[nodiscard]] std::vector<std::vector<ContactNode>> contact_nodes() const;
  static Explicit::Contact contact_at(const ContactNode& n, std::size_t plane);
  // contact forces at the nodes of a plane: the explicit run's, or before it the reactions of
  // the implicit stages' constraints (the K0 state)
  [[nodiscard]] std::vector<Explicit::Contact> contact_state(std::size_t plane) const;
  void explicit_move(double dt); // one velocity-Verlet step
  void explicit_sync();          // u, v, acc, trial ← the explicit state (for observation)
  StepStats explicit_advance(double dt);

  template <class F> double sum(F f) const { return Utilities::MPI::sum(f(), comm); }
};

} // namespace demfem::continuum::fem
