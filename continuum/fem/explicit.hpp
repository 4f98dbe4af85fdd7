// The explicit integrator of the plane-strain solver: central differences in velocity-Verlet
// form with a lumped mass, the internal force cell by cell from cached B̄ rows and the
// constitutive seam (no global matrix), an automatic stable step, rigid bodies as 3-dof bodies,
// Coulomb contact (contact.cpp). It owns its replicated nodal state and reaches the mesh,
// constraints, loads and point states through the model's Core (core.hpp); it starts from the
// Core's fields (the K0 state) and copies its own back into them for observation. Internal
// header (deal.II's flags, C++17).
#pragma once

#include "core.hpp"

namespace demfem::continuum::fem {

class Explicit {
public:
  explicit Explicit(Core& model) : core(model) {}

  // Advance from t to t + dt in ceil(dt/Δt) equal steps no longer than the stable step (set up at
  // the first call).
  StepStats advance(double dt);
  // The automatic step, safety × 2/ω_max with ω_max bounded by the largest element eigenvalue
  // (Irons 1970) [s].
  double stable_step();
  // The first step's set-up without its initial acceleration (a restored state brings its own:
  // Model::restore_explicit_state), and the explicit state copied into the Core's fields.
  void prepare() { setup(); }
  void publish() { sync(); }

  struct Body {
    std::size_t region = 0;
    std::vector<types::global_dof_index> dofs;
    std::vector<std::array<double, 3>> rows; // u_i = rows_i · q
    double M[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    double q[3] = {0, 0, 0}, qv[3] = {0, 0, 0}, qa[3] = {0, 0, 0};
    double q_prev[3] = {0, 0, 0}; // prescribed components one step back
    // A moving structure in Coulomb contact (Region::contact with a DoF not fixed): not
    // meshed (no dofs/rows); M from its outline × density, its dead weight as a generalised
    // force Qw, its soil contacts (indices into `contacts`) solved with it (contact_body)
    bool contact = false;
    double Qw[3] = {0, 0, 0};
    std::vector<std::size_t> contacts;
    long passes = 0, unsettled = 0; // active-set passes; steps that ended unsettled
  };
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
  // A contact record of a node on a plane: its dofs, outward normal and position, no force yet.
  static Contact contact_at(const Core::ContactNode& n, std::size_t plane);

  // The integrator's state (the same on every rank but for the cells).
  struct State {
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
    std::vector<Body> bodies;
    std::vector<Contact> contacts;
    std::vector<double> contact_work; // by plane: work of the contact forces on the soil [J/m]
    // the step the contact forces look ahead over (Δt) and the time to the next velocity (τ: Δt,
    // or Δt/2 at the initial acceleration)
    double contact_dt = 0.0, contact_tau = 0.0;
    long steps = 0;
    // wall time of the steps: total, the cell loop and the reduction (Model::explicit_profile)
    double step_s = 0.0, cells_s = 0.0, reduce_s = 0.0;
  };
  State state;

private:
  Core& core;
  using CellB = Core::CellB;
  using ContactNode = Core::ContactNode;
  using RegionGeom = Core::RegionGeom;

  void setup();
  void gather_classes(); // several ranks: the dof classes of every rank's owned dofs
  void contact_setup();  // contact nodes of Problem::contacts (after the dof classes)
  void accel(double dt); // a from u, v at time t (dt: the step, for prescribed motion)
  void apply_contacts(); // contact forces into a (after the free accelerations)
  // a moving contact body's acceleration and its soil contacts' forces, solved together
  void contact_body(Body& b, double dt);
  void move(double dt); // one velocity-Verlet step
  void sync();          // u, v, acc, trial ← the explicit state (for observation)
};

// Helpers shared by explicit.cpp and contact.cpp.
namespace explicit_detail {
// solve the k×k system A x = b (k ≤ 3) by Gaussian elimination with partial pivoting
void solve_small(int k, double A[3][3], double b[3]);
// Sum of a replicated per-dof array over the ranks, in place (every rank gets the same sums).
void allreduce_sum(std::vector<double>& x, MPI_Comm comm);
// the small rigid motion S(x) q of a body at (x, z) about its pivot p:
// S = [[1, 0, −(z − zp)], [0, 1, x − xp]] (as the tied body's rows)
inline void rigid_at(const double q[3], const Point& p, double x, double z, double out[2]) {
  out[0] = q[0] - q[2] * (z - p.z);
  out[1] = q[1] + q[2] * (x - p.x);
}
// A rigid body's generalised DoFs (x, z, rotation): the free ones listed in `fr` (their count
// returned), a prescribed one's acceleration in `ap` by the central difference of its motion
// (q(t+Δt) − 2q(t) + q(t−Δt))/Δt², a fixed one left at rest.
int free_and_prescribed(const Region& reg, double t, double dt, int fr[3], double ap[3]);
} // namespace explicit_detail

} // namespace demfem::continuum::fem
