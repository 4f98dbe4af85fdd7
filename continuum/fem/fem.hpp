// Internal interface of the deal.II/PETSc plane-strain solver. No deal.II type appears here and
// the header is C++17/C++20-neutral: the solver (fem/*.cpp) compiles with deal.II's flags (C++17),
// run.cpp and the tests with the project's (C++20).
//
// Coordinates: x horizontal, z vertical (up); deal.II's point[0] = x, point[1] = z.
// Stresses are tension-positive (continuum convention); soil compression is negative.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "constitutive/registry.hpp"
#include "demfem/scene/time_function.hpp"

namespace demfem::continuum::fem {

struct Point {
  double x = 0.0;
  double z = 0.0;
};

// MPI (and PETSc) for the lifetime of the object; a no-op when MPI is already initialised.
class MpiScope {
public:
  MpiScope(int& argc, char**& argv);
  ~MpiScope();
  MpiScope(const MpiScope&) = delete;
  MpiScope& operator=(const MpiScope&) = delete;
  static int rank();
  static int size();
  // Collective over every rank: true when `flag` is true on any of them (a write failure on
  // the root ends the run on every rank instead of leaving the others in the next collective).
  static bool any(bool flag);
  // Collective: true when `value` is the same on every rank.
  static bool same(long long value);

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// For library callers (the app) that did not start MPI: starts it once for the process.
void ensure_mpi();

// A region of the mesh with its own material (structures as very stiff elastic bodies).
struct Region {
  std::string name;
  std::vector<Point> outline;   // cells whose centre lies inside get this material
  constitutive::Hooke material; // elastic constants
  double density = 2400.0;
  // external loads on the region (body-force distribution with the given resultant and moment)
  scene::TimeFunction force_x, force_z, moment;
  Point load_point; // where force_x/force_z act
  Point pivot;      // reference point for rotation and moment output
  // Rigid body (scene structures): every dof of the region's cells follows the small rigid
  // motion u = (ux − θ(z − zp), uz + θ(x − xp)) of the pivot p; each of (ux, uz, θ) is fixed
  // (zero), free (driven by loads, weight, inertia and the soil) or prescribed (`motion`).
  // Not rigid: an elastic region with `material`.
  enum class Mode { Fixed, Free, Prescribed };
  bool rigid = false;
  Mode mode[3] = {Mode::Free, Mode::Free, Mode::Free}; // x, z, rotation
  scene::TimeFunction motion[3];                       // [m], [m], [rad]
  bool dead_weight = true;                             // gravity acts on the region
  // Seated (rigid regions whose z mode is Fixed): after the K0 state, a static stage with the
  // vertical DoF free lets the region's dead weight load the soil (the run's soil model); the
  // region is then held at that position and the soil keeps its stresses, so that at t = 0 the
  // soil carries the region's weight (as the DEM packing seats an embedded foundation).
  bool seat = false;
  // In Coulomb contact: the region is not meshed; it is a rigid body at rest in the
  // shaking frame whose faces are Problem::contacts with `region` = its index. The soil keeps its
  // own nodes on those faces (no shared nodes); soil_reaction and soil_pressure come from the
  // contact forces. Explicit integrator. With a mode not Fixed it is a moving rigid body (mass and
  // polar moment from the outline × density, dead weight, its loads and modes as a tied body's)
  // whose faces move with it: the contact is solved with its motion (Explicit::contact_body).
  bool contact = false;
};

// One seated region's initial static stage (Model::seating).
struct Seating {
  std::size_t region = 0;
  double settlement = 0.0; // downward displacement of the pivot during seating [m]
  double soil_fz = 0.0;    // vertical force of the soil on the region after seating [N/m]
  double weight = 0.0;     // the region's dead weight [N/m]
  bool converged = true;
};

struct Mesh {
  double x0 = 0.0, z0 = 0.0;
  std::vector<double> dx, dz; // coarse tensor-grid step sizes
  std::vector<Point> domain;  // soil polygon; cells with centre outside (and outside all
                              // regions) are removed; empty = the whole rectangle
  int refinement = 0;         // global refinements of the coarse grid
  bool periodic_x = false;    // tie the left and right boundaries (shear column)
};

enum class Bc { Free, Roller, Fixed }; // roller: normal component fixed

// Distributed traction on the boundary faces whose centre lies on the segment a–b
// (value × load factor), e.g. a strip load. Pressure p > 0 pushes into the body.
struct Traction {
  Point a, b;
  double pressure = 0.0;
};

// Prescribed rigid motion of the boundary faces whose centre lies on the segment a–b:
// u = load factor × (ux − θ(z − zp), uz + θ(x − xp)) for the constrained components.
struct Patch {
  std::string name;
  Point a, b;
  bool constrain_x = true, constrain_z = true;
  double ux = 0.0, uz = 0.0, rotation = 0.0;
  Point pivot;
};

// Zero-thickness Coulomb contact of the soil with a rigid plane at rest in the shaking frame
// ("boundary friction"; explicit integrator only). The soil nodes on the boundary faces
// whose centre lies on the segment a–b (axis-aligned, as the mesh's faces are) may not cross the
// plane (unilateral: a node pulled away leaves it) and slide along it against Coulomb friction:
// sticking while the tangential force needed stays ≤ μ_static N, sliding against μ_dynamic N
// otherwise. In the implicit stages before t = 0 (K0 state, seating) the nodes stick to the plane
// (both components held; with μ_static = 0: the normal one only, a roller). μ = 0 is a roller
// that lets the soil separate.
struct ContactPlane {
  std::string name;
  Point a, b;
  double mu_static = 0.5, mu_dynamic = 0.2;
  // ≥ 0: a face of that region (Region::contact): its soil reaction, moment and pressure profile
  // come from this plane's contact forces
  int region = -1;
};

// Contact forces on a plane (Model::contact_force): the force of the soil on it, the sums of the
// normal (compression positive) and tangential magnitudes, and the frictional work dissipated
// since t = 0 [J/m]; nodes in contact, of which sliding, and nodes separated from the plane.
struct ContactForce {
  double fx = 0.0, fz = 0.0, moment = 0.0; // moment about the region's pivot (region planes)
  double normal = 0.0, tangential = 0.0;
  double dissipated = 0.0;
  double max_slip = 0.0; // largest tangential displacement of a node along the plane [m]
  int nodes = 0, sliding = 0, open = 0;
};

struct Reaction {
  double fx = 0.0, fz = 0.0, moment = 0.0; // force of the patch on the soil reversed: the force
                                           // the soil exerts on the patch is −(fx, fz)
};

struct Problem {
  Mesh mesh;
  int degree = 2;
  // B-bar (Hughes 1980): volumetric strain projected onto P(degree − 1) per cell, so that
  // isochoric plastic flow (φ = ψ = 0) and near-incompressible soil do not lock
  bool bbar = true;
  // The soil's constitutive model (constitutive/registry.hpp). With a stress-dependent modulus
  // each soil point's E is fixed from its in-plane mean stress after the initial-stress procedure
  // (initialise_gravity: the K0 stresses, and again after seating).
  constitutive::Material soil;
  double density = 1700.0;
  std::vector<Region> regions; // material id k+1
  // Soil–structure interface. < 0: tied (the soil next to a structure is ordinary soil). ≥ 0:
  // frictional: the soil cells sharing a face with a rigid region form a thin Mohr–Coulomb layer
  // with this friction angle [rad], `interface_cohesion` and no dilation (one cell thick).
  double interface_friction = -1.0;
  double interface_cohesion = 0.0;
  double gravity = 9.81; // along −z
  Bc left = Bc::Roller, right = Bc::Roller, bottom = Bc::Fixed, top = Bc::Free;
  bool fix_z_everywhere = false; // pure horizontal kinematics (shear column)
  std::vector<Traction> tractions;
  std::vector<Patch> patches;
  // Coulomb contact planes (ContactPlane; explicit integrator only). Their nodes ignore the box
  // boundary conditions in the explicit run.
  std::vector<ContactPlane> contacts;
  std::string linear_solver = "direct"; // cg-amg | gmres-amg | direct (= the scene default)
  double newton_tolerance = 1e-8;
  int newton_max_iterations = 25;
  // diagnostics, written to the model's log (run.cpp sets them from DEMFEM_NEWTON_TRACE and
  // DEMFEM_TANGENT_CHECK): every step's Newton history (residual, return regions, line-search α);
  // the directional derivative of the residual along each Newton step against −R
  bool newton_trace = false;
  bool tangent_check = false;
  // dynamics
  double newmark_beta = 0.25, newmark_gamma = 0.5;
  double rayleigh_alpha = 0.0, rayleigh_beta = 0.0;
  // Lysmer & Kuhlemeyer (1969) dashpots t = −ρ(c_p v_n n + c_s v_t) on the boundaries whose
  // flag is set (left, right, bottom, top); only unconstrained components feel them.
  bool absorbing = false;
  bool absorbing_sides[4] = {true, true, true, false};
  // Time integration of dynamic_step: "implicit" (Newmark-β with Newton) or "explicit" (central
  // differences, lumped mass, cell-wise internal force, automatic stable step; N MPI ranks).
  std::string integrator = "implicit";
  double explicit_safety = 0.8; // fraction of the critical step (element bound, Irons 1970)
  double explicit_dt = 0.0;     // explicit step [s]; 0 = automatic; above the stable step: error
  // FLAC-style local (non-viscous) damping, explicit only: f_d = −α |f| sign(v) per dof
  // (Cundall 1987); 0 = none
  double local_damping = 0.0;
  int shaking_component = -1;  // 0 = x, 1 = z, −1 = none
  scene::TimeFunction shaking; // base acceleration [m/s²] applied as body force ρ·a(t)
};

struct QpStress {
  double x = 0.0, z = 0.0;
  double sxx = 0.0, szz = 0.0, sxz = 0.0, syy = 0.0;
  int material = 0;
};

struct StepStats {
  bool converged = true;
  int newton_iterations = 0;
  int linear_iterations = 0;
  int cuts = 0;
  double residual = 0.0;
  long substeps = 0; // explicit central-difference steps taken
};

class Model {
public:
  explicit Model(const Problem& problem);
  ~Model();
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;

  [[nodiscard]] std::size_t n_dofs() const;
  [[nodiscard]] std::size_t n_cells() const;

  // Geostatic stresses. use_k0: σzz = −ρ g depth (depth below the domain top at that x),
  // σxx = σyy = K0 σzz, followed by an equilibrium correction with the regions weightless (their
  // weight acts in the steps that follow: a structure released at t = 0, as in the DEM scenes);
  // otherwise gravity (regions included) is switched on in `steps` load steps. Displacements are
  // reset to zero afterwards; stresses are kept.
  //
  // With use_k0, regions marked `seat` are then seated on the soil (Region::seat): their vertical
  // DoF is freed, their weight applied statically (Newton, step cuts), and the DoF fixed again at
  // the seated position; the returned statistics include this stage. See seating().
  StepStats initialise_gravity(bool use_k0, double k0, int steps);
  // The seated regions' settlement and soil reaction (empty when none was seated).
  [[nodiscard]] const std::vector<Seating>& seating() const;
  // Static equilibrium at load factor `lambda` (tractions and patches scale with it; gravity is
  // on when it was initialised). Newton with line search; the increment is halved on failure.
  StepStats static_step(double lambda);
  // Advance from t to t + dt with patches/tractions at factor 1: one Newmark-β step (Newmark
  // 1959) when `integrator` is implicit; with the explicit integrator, ceil(dt/Δt) equal central-
  // difference steps no longer than the stable step (StepStats::substeps).
  StepStats dynamic_step(double dt);
  // Explicit integrator: the automatic step, safety × 2/ω_max with ω_max bounded by the largest
  // element eigenvalue (Irons 1970) [s].
  [[nodiscard]] double stable_time_step();
  // Explicit integrator: wall time of this rank's central-difference steps, split into the cell
  // loop (stress update and internal force of its cells), the reduction of the internal force
  // over the ranks, and the replicated rest (nodal update, loads, damping, contact, rigid bodies).
  struct ExplicitProfile {
    long steps = 0;
    int ranks = 1;
    std::size_t cells = 0; // this rank's cells with stresses
    double cells_s = 0, reduce_s = 0, nodal_s = 0;
  };
  [[nodiscard]] ExplicitProfile explicit_profile() const;
  // Explicit integrator, between dynamic steps (state.cpp): its state as bytes for a checkpoint
  // (the time, the nodal vectors, the rigid bodies' motion, the contact nodes' forces and states,
  // this rank's quadrature points' states, the .pvd's records), and that state put back into a
  // model built from the same problem and initialised the same way (initialise_gravity), in place
  // of its K0 state: the steps that follow are the saved run's, bit for bit. Restoring throws
  // std::runtime_error when the bytes do not fit the model (another mesh, degree, contact set or
  // MPI rank count).
  [[nodiscard]] std::string explicit_state() const;
  void restore_explicit_state(std::string_view bytes);
  // Initial displacement for free vibration tests (gravity off).
  void set_displacement(const std::function<Point(Point)>& u);

  [[nodiscard]] double time() const;
  // Displacement at a point (collective: every rank must call).
  [[nodiscard]] Point displacement(Point p) const;
  [[nodiscard]] Point velocity(Point p) const;
  [[nodiscard]] Reaction reaction(std::size_t patch) const; // collective
  // Contact forces on Problem::contacts[plane] (explicit runs; zero before the first step).
  [[nodiscard]] ContactForce contact_force(std::size_t plane) const;
  // Mean displacement and rotation (½ curl u averaged over the area) of region k (collective).
  struct RegionMotion {
    double ux = 0, uz = 0, rotation = 0;
  };
  // Rigid regions: the pivot's displacement and the rotation θ (counter-clockwise).
  [[nodiscard]] RegionMotion region_motion(std::size_t region) const;
  // Force of the soil on region k (nodal reactions of the soil cells at the region's dofs:
  // internal force − body force + inertia + damping) and its moment about the region's pivot
  // (counter-clockwise positive). Collective.
  [[nodiscard]] Reaction soil_reaction(std::size_t region) const;
  // Normal pressure of the soil on region k (compression positive) from the soil stresses
  // interpolated to the soil–region faces, integrated over the faces in `bins` equal z bins
  // between z0 and z1 and divided by the bin height [Pa] (per metre thickness); `force` receives
  // the integral of the traction σ·n over all those faces (force of the soil on the region).
  [[nodiscard]] std::vector<double> soil_pressure(std::size_t region, double z0, double z1,
                                                  int bins, Reaction* force = nullptr) const;
  // Explicit runs: linear momentum (px, pz) [kg·m/s per m] and angular momentum about the origin
  // [kg·m²/s per m] of the soil (lumped masses at their nodes' reference positions) and the
  // moving contact bodies (M_q q̇ moved from the pivot to the origin); zero before the first step.
  struct Momentum {
    double px = 0, pz = 0, angular = 0;
  };
  [[nodiscard]] Momentum momentum() const;
  // Explicit runs: one line per moving contact body (Region::contact with a DoF not fixed): its
  // contact nodes, active-set passes per step and the steps whose set did not settle.
  [[nodiscard]] std::string contact_body_summary() const;
  // ½ vᵀM v + ½ uᵀK0 u: kinetic plus elastic strain energy (linear elastic problems) [J/m]
  [[nodiscard]] double elastic_energy() const;
  [[nodiscard]] std::vector<QpStress> stresses() const; // locally owned only
  // Checked atomic writes (scene::write_file_atomic); collective: a failure on any rank throws
  // scene::WriteError on every rank, naming the file and the cause.
  void write_vtu(const std::string& directory, const std::string& basename, int index);
  void write_pvd(const std::string& directory, const std::string& basename) const;
  [[nodiscard]] const std::string& log() const;

private:
  friend double stable_time_step(const Problem& pb);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The explicit integrator's automatic step of `pb` (Model::stable_time_step) from its mesh, dofs
// and materials alone: no constraints, matrices or K0 state (cheap enough for a scene check).
[[nodiscard]] double stable_time_step(const Problem& pb);

} // namespace demfem::continuum::fem
