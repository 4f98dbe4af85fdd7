// The problem vocabulary shared by the DEM engine and the continuum solver.
// Everything is SI: metres, seconds, kilograms, newtons, radians (angles given in degrees in the
// file are converted on load). Coordinates: x to the right, z up, gravity along −z (paper §1).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "demfem/scene/params.hpp"
#include "demfem/scene/time_function.hpp"

namespace demfem::scene {

struct Vec2 {
  double x = 0.0;
  double z = 0.0;
};
using Polyline = std::vector<Vec2>;
using Polygon = std::vector<Vec2>; // closed implicitly, counter-clockwise after loading

enum class Solver { Dem, Continuum };

// ---- registries: the keywords of the file, shared by docs, errors and code -------------------
enum class StructureKind { Pile, Footing, Wall };
inline constexpr std::array<const char*, 3> kStructureKindNames = {"pile", "footing", "wall"};

// Degree-of-freedom mode of a rigid structure.
//   fixed: never moves; free: moves under contact forces, dead weight and loads;
//   prescribed: follows the motion time function; pivot: (rotation only) rotates about the pivot,
//   which stays fixed (paper eqs. 5.2–5.7)
enum class DofMode { Fixed, Free, Prescribed };
inline constexpr std::array<const char*, 3> kDofModeNames = {"fixed", "free", "prescribed"};

// The [[probe]] kinds; the keys each takes are in probe_spec.hpp.
enum class ProbeKind { Energy, WallThrust, PressureProfile, SurfaceProfile, Loci, Coordination };
inline constexpr std::array<const char*, 6> kProbeKindNames = {
    "energy", "wall-thrust", "pressure-profile", "surface-profile", "loci", "coordination"};

enum class EventAction { SetFriction, OpenWall };
inline constexpr std::array<const char*, 2> kEventActionNames = {"set-friction", "open-wall"};

// ---- sections ----------------------------------------------------------------------------------
struct Info {
  std::string name;
  std::string description;
  std::vector<Solver> solvers{Solver::Dem};
  double duration = 1.0;  // simulated time [s]
  unsigned long seed = 1; // packing and any randomness
};

struct RadiusDistribution {
  enum class Kind { Uniform, Equal, Table };
  Kind kind = Kind::Uniform;
  double min = 0.0;                             // uniform: lower bound; equal: the radius
  double max = 0.0;                             // uniform: upper bound; equal: the radius
  std::vector<std::pair<double, double>> table; // (radius, relative frequency)
};

// How packing places the particles before they fall: on a hexagonal lattice with
// jitter (dense, nearly ordered beds), or at random sequential positions at a low placement
// density (disordered beds; with raised deposition friction, loose ones).
enum class Placement { Lattice, Random };
inline constexpr std::array<const char*, 2> kPlacementNames = {"lattice", "random"};

struct Packing {
  Placement placement = Placement::Lattice;
  double ke_ratio = 1e-4; // stop depositing when kinetic energy < ke_ratio · released potential
  double max_time = 20.0; // give up depositing after this simulated time [s]
  double damping = 0.0;   // extra global damping ratio during deposition only
  std::string cache;      // directory for reusable packings ("" = <out>/packing)
  // Target density: [soil.dem.packing] target = { porosity = n } or
  // { void_ratio = e } (2D: void area / solid area, n = e/(1+e)), optional tolerance (default
  // 0.005); target = "none" deposits as is. Reached by raised-friction deposition (pack.hpp).
  std::optional<double> target_porosity;
  bool target_as_void_ratio = false; // how the file gave it (for the resolved dump)
  double target_tolerance = 0.005;   // |achieved − target porosity| accepted
};

struct DemSoil {
  int count = 0;
  RadiusDistribution radius;
  double density = 2650.0; // [kg/m³]
  double thickness = 1.0;  // out-of-plane thickness: m = ρπr²·t, I = ½mr² (PFC2D)
  // The contact law and its sub-models (the `contact` and `rolling` slots: `models` below, their
  // keys and defaults in dem/contact/), and the friction of the soil's material:
  double mu_static = 0.5;  // μ_s, sticking limit
  double mu_dynamic = 0.2; // μ_D, while sliding
  double damping_c = 0.0;  // global translational damping C (eq. 2.1) [1/s, per mass]
  double damping_d = 0.0;  // global rotational damping D (eq. 2.2) [1/s, per inertia]
  double dt = 0.0;         // 0 = automatic
  // Automatic Δt = dt_safety × the stable limit (dem/stable_step.hpp; disks:
  // √(m_min/max(2k_n, 6k_s))); 0.14 gives 0.099√(m_min/k_n) for k_s ≤ k_n/3, ≈ 22 steps per
  // contact.
  double dt_safety = 0.14;
  double max_overlap = 0.5; // blow-up: overlap beyond this fraction of the radius
  // Energy-closure watch during a run, checked at every probe: |ΔE_total| over the
  // largest energy put in so far (gravity + external work + springs, or the initial kinetic
  // energy). Above energy_warning: one warning naming the step; above energy_limit: the run
  // stops (exit 1) naming step, time and the particle with the most kinetic energy. 0 = off.
  double energy_warning = 0.05;
  double energy_limit = 1.0;
  Polygon fill; // region filled by packing (default: the domain polygon)
  Packing packing;
  // Explicit particles [x, z, r, vx, vz, ω] (verification scenes); when given, no packing is
  // generated and count must equal their number.
  std::vector<std::array<double, 6>> particles;
  // The file the particles were read from (key particles_file, a .csv or .npy path relative to
  // the scene file; stored resolved). Empty when they are listed inline or packed.
  std::string particles_file;
  // Mass convention: false (particle_mass = "disk"): m = ρπr²·thickness, I = ½mr² (PFC2D, the
  // paper); true ("sphere"): m = ρ(4/3)πr³, I = (2/5)mr², what LAMMPS's atom_style sphere gives
  // in 2D (used to race LAMMPS on an identical scene).
  bool sphere_mass = false;
  // The models of the vocabulary's DEM slots (vocabulary.hpp), in its order, as read.
  std::vector<ModelChoice> models;
  [[nodiscard]] const ModelChoice* model(std::string_view key) const {
    for (const auto& m : models)
      if (m.key == key) return &m;
    return nullptr;
  }
  [[nodiscard]] ModelChoice* model(std::string_view key) {
    for (auto& m : models)
      if (m.key == key) return &m;
    return nullptr;
  }
};

struct ContinuumSoil {
  // The models of the vocabulary's continuum slots (vocabulary.hpp), in its order, as read: the
  // constitutive model (soil.continuum.model) with its parameter blocks (young, poisson,
  // friction_angle, …: continuum/constitutive/, which owns their keys, defaults and meaning).
  std::vector<ModelChoice> models;
  [[nodiscard]] const ModelChoice* model(std::string_view key) const {
    for (const auto& m : models)
      if (m.key == key) return &m;
    return nullptr;
  }
  [[nodiscard]] ModelChoice* model(std::string_view key) {
    for (auto& m : models)
      if (m.key == key) return &m;
    return nullptr;
  }
  double density = 1700.0; // [kg/m³]
  double k0 = -1.0;        // lateral earth pressure at rest (<0: 1 − sin φ, Jaky)
  // ground surface [m]: the continuum soil is the domain polygon below z = surface (e.g. the
  // height of the deposited DEM bed); unset: the whole domain polygon
  std::optional<double> surface;
  // calibrate = "dem": young, poisson, friction_angle, cohesion, dilation_angle,
  // dilation_cutoff, modulus_exponent, modulus_reference_stress, density, k0 and surface come
  // from `demfem calibrate` (the app fills them in
  // before the continuum runs, compare::apply_calibration); a value stated in the file wins.
  bool calibrate_dem = false;
  std::vector<std::string> given; // the keys stated in the file (or set by a variant)
  // key → where its value came from (filled by apply_calibration; dumped as a table)
  std::vector<std::pair<std::string, std::string>> provenance;
  // calibrate = "dem": structures the DEM packing seated on its bed, (name, vertical offset [m]);
  // the continuum places them there too (continuum::run).
  std::vector<std::pair<std::string, double>> structure_offsets;
};

struct ContinuumOptions {
  int refinement = 3;
  int degree = 2;
  // Graded coarse grid (continuum/README.md): coarse cells of mesh_size_near [m] next to the
  // structures (their bounding box), growing by mesh_grading per cell away from it up to the
  // default coarse size min(W, H)/4; the run's cells are these / 2^refinement. 0 = uniform.
  double mesh_size_near = 0.0;
  double mesh_grading = 1.25;
  bool bbar = true; // B-bar: volumetric strain projected onto P(degree−1) per cell (no locking)
  double dt = 0.0;  // dynamic step [s] (0 = automatic)
  // Where `dt` was given in the scene file (line, column; 0 = not given): an explicit step above
  // the stable limit is refused there, by the scene check and by the run (validate.hpp).
  int dt_line = 0, dt_column = 0;
  double newmark_beta = 0.25;
  double newmark_gamma = 0.5;
  double rayleigh_alpha = 0.0;
  double rayleigh_beta = 0.0;
  // rayleigh_alpha or rayleigh_beta stated in the file: a calibrated continuum keeps them
  // (otherwise `calibrate = "dem"` sets both from the DEM's small-strain damping ratio)
  bool rayleigh_stated = false;
  bool absorbing = false; // Lysmer dashpots on the sides and base
  // cg-amg | gmres-amg | direct. One default with continuum::fem::Problem's (a test checks):
  // MUMPS, robust on the near-singular tangents of yielding soil; cg-amg for large meshes
  std::string linear_solver = "direct";
  // Soil–structure/boundary interface: tied (shared nodes; base fixed, sides on rollers),
  // frictional (a one-cell Mohr–Coulomb layer at the structures), coulomb (explicit only:
  // zero-thickness Coulomb contact with the DEM's walls and fixed structures, with their μ;
  // continuum/README.md)
  std::string interface = "tied";
  // With interface = "coulomb": structures that move (a DoF free or prescribed) are rigid bodies
  // in Coulomb contact with the soil ("contact", continuum/README.md) or tied to it as before
  // ("tied"); structures with every DoF fixed are in contact either way
  std::string structure_interface = "contact";
  double interface_friction_angle = 0.3491; // [rad]
  int load_steps = 20;                      // static procedure
  double newton_tolerance = 1e-8;
  int newton_max_iterations = 25;
  // small-strain validity limit [m]: the run stops (successfully, with a note) when a structure's
  // pivot has moved further than this; 0 = no limit
  double max_displacement = 0.0;
  // dynamics: "implicit" (Newmark-β + Newton) or "explicit" (central differences, lumped mass,
  // automatic step = explicit_safety × the critical step; `dt` then caps the step);
  // local_damping: FLAC-style non-viscous damping coefficient (explicit only; 0 = none)
  std::string integrator = "implicit";
  double explicit_safety = 0.8;
  double local_damping = 0.0;
  // seat_structures: structures held vertically (dof_z = "fixed") start resting on the soil under
  // their own weight (a static stage after the K0 state with dof_z free, then fixed where they
  // settled), as the DEM packing seats them. Absent: every such structure embedded in the soil
  // (soil on both sides and below it); true: every such structure with soil below it; false: none.
  std::optional<bool> seat_structures;
};

struct Soil {
  std::optional<DemSoil> dem;
  std::optional<ContinuumSoil> continuum;
};

struct Wall {
  std::string name;
  Polyline points;
  std::optional<double> mu_static; // default: the soil's
  std::optional<double> mu_dynamic;
  std::optional<double> opens_at; // removed at this time [s] (Ontake river hole)
  bool record = false;            // write its reaction history
};

struct Structure {
  std::string name;
  StructureKind kind = StructureKind::Footing;
  Polygon outline; // counter-clockwise
  // When given as a rectangle, its parameters are kept so variants can override them.
  double width = 0.0;
  double height = 0.0;
  Vec2 base_centre;        // centre of the base edge
  double density = 2400.0; // [kg/m³] with the soil's thickness; or mass
  double mass = 0.0;       // [kg] (0 = from density and area)
  double inertia = 0.0;    // about the pivot [kg·m²] (0 = from the outline)
  Vec2 pivot;              // rotation centre (default: base centre, paper §5)
  DofMode dof_x = DofMode::Fixed;
  DofMode dof_z = DofMode::Fixed;
  DofMode dof_rotation = DofMode::Fixed;
  TimeFunction motion_x, motion_z, motion_rotation; // prescribed displacements [m], [rad]
  TimeFunction force_x, force_z, moment;            // external loads [N], [N·m]
  Vec2 load_point; // where force_x, force_z act (default: top centre)
  bool dead_weight = true;
  std::optional<double> mu_static; // soil–structure friction (default: the soil's)
  std::optional<double> mu_dynamic;
  std::vector<std::string> record; // thrust, pressure-profile, motion
};

struct Shaking {
  char direction = 'x';      // 'x' or 'z'
  TimeFunction acceleration; // A·sin(2πft) [m/s²] applied as body force m·a
};

struct Load {
  double gravity = 9.81; // [m/s²] along −z
  std::optional<Shaking> shaking;
};

struct Group {
  std::string name;
  Polygon region; // particles whose centre is inside at the time of use
};

struct Event {
  double time = 0.0;
  EventAction action = EventAction::SetFriction;
  std::string group; // set-friction
  std::string wall;  // open-wall
  double mu_static = 0.0;
  double mu_dynamic = 0.0;
};

struct Probe {
  ProbeKind kind = ProbeKind::Energy;
  std::string target;       // wall-thrust, pressure-profile: a structure or wall name
  double interval = 0.0;    // [s] this probe samples at (0 = output.probe_interval)
  int bins = 20;            // pressure and surface profiles
  std::vector<Vec2> points; // loci: the particles nearest to these points are traced
};

// How the DEM's .vtp snapshots are compressed: lz4 (the default: ≈ 4× less CPU per snapshot than
// zlib, ≈ 0.7 s of a 12 s paper wall run; files ≈ 1.3× zlib's; ParaView ≥ 5.5, VTK ≥ 8), zlib
// (level 1; every VTK reader), none (no CPU, files ≈ 2.2× zlib's).
enum class VtkCompression { Zlib, Lz4, None };
inline constexpr std::array<const char*, 3> kVtkCompressionNames = {"zlib", "lz4", "none"};

struct Output {
  double interval = 0.5;        // snapshots (.vtp/.vtu) every … [s]
  double probe_interval = 0.01; // time series every … [s]
  bool vtk = true;
  VtkCompression vtk_compression = VtkCompression::Lz4;
  bool force_chains = true;
  bool figures = true;
  double checkpoint_interval = 0.0; // [s] (0 = at the end and on interrupt only)
  // Snapshot series for the figures [s], increasing: the times the paper shows as a
  // series; each is drawn from the nearest .vtp snapshot. Empty: six evenly spaced times.
  std::vector<double> series;
};

struct Scene {
  std::string source_file;         // where it was read from
  std::string variant;             // "" for the base scene
  std::string variant_description; // the [[variant]]'s description ("" if none)
  Info info;
  Polygon domain;
  Soil soil;
  std::vector<Wall> walls;
  std::vector<Structure> structures;
  Load load;
  std::vector<Group> groups;
  std::vector<Event> events;
  std::vector<Probe> probes;
  Output output;
  ContinuumOptions continuum;

  [[nodiscard]] bool uses(Solver s) const;
  [[nodiscard]] std::string label() const {
    return variant.empty() ? info.name : info.name + "/" + variant;
  }
  [[nodiscard]] const Structure* structure(const std::string& name) const;
  [[nodiscard]] const Wall* wall(const std::string& name) const;
  [[nodiscard]] const Group* group(const std::string& name) const;
};

// ---- geometry helpers used by validation and both solvers --------------------------------------
[[nodiscard]] double signed_area(const Polygon& p); // > 0 when counter-clockwise
// The part of polygon p where a·x + b·z ≤ c (Sutherland–Hodgman clip against a half-plane).
[[nodiscard]] Polygon clip(const Polygon& p, double a, double b, double c);
[[nodiscard]] bool self_intersects(const Polygon& p);
[[nodiscard]] bool contains(const Polygon& p, Vec2 q); // even–odd rule
// Axis-aligned bounding box of a point list (all zero when empty).
struct Bounds {
  double x0 = 0, x1 = 0, z0 = 0, z1 = 0;
};
[[nodiscard]] Bounds bounds(const std::vector<Vec2>& p);
// Distance from q to the segment a–b.
[[nodiscard]] double segment_distance(Vec2 q, Vec2 a, Vec2 b);
// The structure moved vertically by dz: outline, base centre, pivot and load point.
[[nodiscard]] Structure shifted(Structure st, double dz);
// The structure turned by rot [rad] (counter-clockwise) about its pivot: outline, base centre and
// load point (the engine's convention for a structure's rotation).
[[nodiscard]] Structure rotated(Structure st, double rot);
[[nodiscard]] Vec2 centroid(const Polygon& p);
// Unit normal for a wall's or structure's thrust (walls.csv <w>.thrust = F·n, F the soil force on
// it): perpendicular to the chord from the first to the last vertex of `outline` (a closed outline:
// its first edge), oriented out of the soil, from the domain's centroid towards the chord's
// midpoint, so the thrust is > 0 when the soil presses on the wall and < 0 when it pulls (a tied
// continuum in tension), whichever way the wall was drawn. Without a domain (or with the centroid
// on the chord's line) the chord's right-hand normal (dz, −dx)/l.
[[nodiscard]] Vec2 thrust_normal(const std::vector<Vec2>& outline, const Polygon& domain);

template <std::size_t N>
[[nodiscard]] const char* keyword(const std::array<const char*, N>& names, auto e) {
  return names[static_cast<std::size_t>(e)];
}

} // namespace demfem::scene
