// The DEM engine core: particles (disks), contact laws, persistent contact history, cell-grid
// neighbour search with a Verlet skin, line walls / polylines, rigid structures, loads and a
// symplectic Euler integrator (paper eqs. 2.1–2.18). Sign convention: dem/contact/contact.hpp.
//
// Usage (tests, run.cpp):
//   Engine e(config);                    // config from the scene (make_config) or by hand
//   e.add_particle(x, z, r, vx, vz, ω);  // explicit particles
//   e.add_wall({{x0, z0}, {x1, z1}});    // polyline wall, two-sided
//   e.add_structure(structure);          // rigid polygon (pile, footing, wall)
//   e.set_dt(e.auto_dt());               // or a chosen Δt (checked against the stable limit)
//   e.step(); …                          // or run_steps(n), run_until(t, n)
// Probes read particles(), structures(), boundary_reaction(), energy(), contacts().
// Everything here is plain computation: no I/O.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "demfem/dem/contact/registry.hpp"
#include "demfem/dem/state.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::dem {

struct Material {
  double mu_s = 0.5; // static friction
  double mu_d = 0.2; // dynamic friction
};

using contact::AnyContactLaw;

struct EngineConfig {
  // The contact law with its rolling sub-model and their parameters (dem/contact/registry.hpp:
  // make_law); the default: cundall-rebound at its defaults, no rolling resistance.
  AnyContactLaw law;
  double damping_c = 0.0, damping_d = 0.0; // global damping (eqs. 2.1, 2.2) [1/s]
  double density = 2650.0, thickness = 1.0;
  // false: disks m = ρπr²t, I = ½mr² (PFC2D); true: spheres m = ρ(4/3)πr³, I = (2/5)mr² (LAMMPS
  // atom_style sphere in 2D, for the race against LAMMPS)
  bool sphere_mass = false;
  double gravity = 9.81;    // along −z [m/s²]
  double max_overlap = 0.5; // blow-up: δ > max_overlap · r
  double dt_safety = 0.14;  // automatic Δt = dt_safety · stable_dt() (scene.hpp)
  std::vector<Material> materials{Material{}}; // index 0: the soil
  // Base shaking as body force m·a(t) (paper §6); direction 'x' or 'z'; inactive when !shaking.
  bool shaking = false;
  char shaking_direction = 'x';
  scene::TimeFunction shaking_acceleration;
  // Neighbour search
  double skin_factor = 0.6; // Verlet skin = skin_factor · r_min (bench/RESULTS.md, "Verlet skin")
  int reorder_every = 25;   // particle reordering every … neighbour rebuilds (0 = never)
  // The order reorder() gives the particles, by their cell of size 2·r_max: `columns` cuts the
  // bed into columns across its longer side and runs along each column (the neighbours of a
  // particle lie within about two columns' particles of it in memory, so the pair loop's partner
  // reads stay in cache: 1.2–1.8× the speed of `morton` at 10⁵ disks, bench/RESULTS.md);
  // `morton` is the Z-order curve (an alternative order, kept for comparison).
  enum class ParticleOrder { columns, morton } particle_order = ParticleOrder::columns;
  // Threads (OpenMP) for the force loop and the integration: 0 = OpenMP default. Results are
  // bit-identical between runs at the same count, and equal to round-off across counts.
  int threads = 1;
  std::size_t parallel_min_particles = 2048; // fewer particles: one thread (no fork overhead)
  // threads > 1: the work is always cut into `threads` parts (so results depend on that count
  // only), but how many threads run the parts is chosen by measurement while the run goes: a
  // team of 1 takes over when the full team is slower (a core shared with another process makes
  // every barrier wait for a descheduled thread). false: always the full team.
  bool adaptive_threads = true;
  // Pair loop of cundall-rebound without tension or rolling resistance: `simd` the blocked,
  // vectorised loop with the widest instruction set the processor has (AVX-512, AVX2 or the
  // baseline; pair_kernel.hpp); `avx2` the same with AVX2 at most; `portable` built for the
  // baseline instruction set only; `scalar` the one-pass loop of the other laws. All give
  // bit-identical results; the switch is for benchmarks and tests.
  enum class PairKernel { simd, avx2, portable, scalar } pair_kernel = PairKernel::simd;
};

// Δt refused by Engine::set_dt: not positive, or above the stable limit.
struct StepRefused : std::runtime_error {
  StepRefused(double dt_, double limit_, std::string formula_, double auto_dt_);
  double dt, limit, auto_dt;
  std::string formula; // how the limit was computed (stable_step.hpp)
};

// Engine configuration from a scene's [soil.dem] and [load] sections.
[[nodiscard]] EngineConfig make_config(const scene::Scene& scene);

// State of one rigid structure. Displacements are those of the pivot; rotation is
// counter-clockwise positive (the paper's foundation θ is clockwise positive: θ_paper = −rotation).
struct StructureState {
  std::string name;
  double mass = 0.0, inertia = 0.0;       // inertia about the pivot [kg·m²]
  double px0 = 0.0, pz0 = 0.0;            // initial pivot [m]
  double ux = 0.0, uz = 0.0, rot = 0.0;   // pivot displacement [m], rotation [rad]
  double vx = 0.0, vz = 0.0, omega = 0.0; // [m/s], [rad/s]
  double cx_local = 0.0, cz_local = 0.0;  // centroid relative to the pivot, unrotated [m]
  // Soil (particle) reaction on the structure in the last step: force and moment about the pivot.
  double soil_fx = 0.0, soil_fz = 0.0, soil_moment = 0.0;
  double applied_fx = 0.0, applied_fz = 0.0, applied_moment = 0.0; // external loads (about pivot)
  scene::Structure spec; // modes, time functions, load point
  std::uint32_t first_vertex = 0, vertex_count = 0;
  std::uint32_t boundary = 0; // index into the boundary list
};

// Energy budget (probe "energy"). Closure: kinetic + rotational + potential + springs +
// dissipated − external_work = constant (the value at the first call of energy()).
struct EnergyBudget {
  double kinetic = 0.0;       // ½ m v², particles and free structures [J]
  double rotational = 0.0;    // ½ I ω² [J]
  double potential = 0.0;     // gravity, m g z (relative to the start) [J]
  double spring_normal = 0.0; // [J]
  double spring_shear = 0.0;  // [J]
  double friction = 0.0;      // dissipated by sliding, cumulative [J]
  double damping = 0.0;       // dissipated by dashpots and global damping, cumulative [J]
  double rebound = 0.0;       // dissipated by the rebound rule, cumulative [J]
  double external_work = 0.0; // shaking, structure loads, prescribed motions, cumulative [J]
  double gravity_work = 0.0;  // −(potential change) [J]
  // ½ m v² + ½ I ω² that particles carried out of the scene when they were removed (fell through
  // an opened wall, the paper's §3 "3D loss"), cumulative [J]. A removed particle's potential stays
  // in `potential` at the height where it left, so gravity does no work on it afterwards.
  double left_scene = 0.0;
  [[nodiscard]] double total() const {
    return kinetic + rotational + potential + spring_normal + spring_shear + friction + damping +
           rebound + left_scene - external_work;
  }
};

struct EngineStats {
  long long steps = 0;
  long long neighbour_rebuilds = 0;
  long long reorders = 0;
  long long structure_updates = 0; // stays 0 for scenes without structures (issue item 8)
  std::size_t pair_entries = 0;    // particle pairs within cut-off + skin
  std::size_t boundary_entries = 0;
  // Wall-clock seconds spent in the neighbour rebuild (incl. reorder) and the force loops, with
  // the integration when threads_in_use() > 1 (each part integrates its particles with its
  // forces, on a team of one as well) (profiling; not part of the state).
  double rebuild_seconds = 0.0, force_seconds = 0.0;
  // threads > 1: steps run by the full team / by one thread (adaptive team), team switches.
  long long team_full_steps = 0, team_one_steps = 0, team_switches = 0;
  // Of the full team's steps, those run many to a parallel region (run_until, run_steps).
  long long team_region_steps = 0;
  // Probes of the full team left out because no other CPU had been idle (set_idle_source).
  long long team_probes_skipped = 0;
  // cundall-rebound: contacts that first touched above V_0; of them, those sharing a particle
  // with another such contact in the same step (one collision, Engine::apply_rebounds).
  long long rebound_contacts = 0, rebound_shared = 0;
};

// Boundary = a wall polyline or a structure outline, made of segment and vertex features.
struct Boundary {
  std::string name;
  std::uint32_t first_vertex = 0, vertex_count = 0;
  bool closed = false; // structures: closed polygon, one-sided edges (outward normal)
  bool active = true;  // false once opened
  int structure = -1;  // index into structures() or −1 for a wall
  double mu_s = 0.5, mu_d = 0.2;
  bool own_friction = false;                 // false: use the particle's material
  double reaction_x = 0.0, reaction_z = 0.0; // force of the particles on it, last step [N]
};

namespace detail {
// A contact that first touched above V_0 in this step (cundall-rebound): its impulse is applied
// after the pair and boundary loops, in a fixed order (Engine::apply_rebounds).
struct ReboundEvent {
  static constexpr std::uint32_t kBoundary = ~0u; // j of a particle–boundary contact
  std::uint32_t i = 0, j = kBoundary;
  std::int32_t boundary = -1; // bd_.list index when j == kBoundary
  double nx = 0.0, nz = 0.0;  // unit normal from j (or the boundary) towards i
  double vn = 0.0, to = 0.0;  // approach speed at first touch; the approach the impulse leaves
  double m_eff = 0.0;         // m_i m_j/(m_i + m_j), m_i against a boundary [kg]
  double rx = 0.0, rz = 0.0;  // structure contact: contact point − pivot [m]
};

// Where one part of the pair loop adds its forces: the particle arrays for the particles below
// `end` (its own range), the halo arrays (index j − end) for the partners beyond it; the part's
// rebound events go to `events`.
struct ForceTarget {
  double *fx, *fz, *tq;
  double *hx, *hz, *ht;
  std::size_t end;
  std::vector<ReboundEvent>* events;
  void add_to_partner(std::uint32_t j, double Fx, double Fz, double Tj) const {
    const bool own = j < end; // else the halo of partners beyond this part's range
    const std::size_t jj = own ? j : j - end;
    (own ? fx : hx)[jj] -= Fx;
    (own ? fz : hz)[jj] -= Fz;
    (own ? tq : ht)[jj] -= Tj;
  }
};
} // namespace detail

class Engine {
public:
  explicit Engine(EngineConfig config);

  // ---- building ---------------------------------------------------------------------------
  std::uint32_t add_particle(double x, double z, double r, double vx = 0.0, double vz = 0.0,
                             double omega = 0.0, std::uint16_t material = 0);
  // Room for n particles in all in every particle array, before add_particle: a large set is then
  // added without the arrays' growth by doubling (which holds the old and the new array at once).
  void reserve_particles(std::size_t n);
  // Returns the boundary index. Walls are two-sided; friction defaults to the particle's.
  int add_wall(const std::vector<scene::Vec2>& points, const std::string& name = "wall",
               const double* mu_s = nullptr, const double* mu_d = nullptr);
  int add_wall(const scene::Wall& wall);
  // Rigid polygon; mass and inertia from density·thickness unless given. Returns its index.
  int add_structure(const scene::Structure& s);
  std::uint16_t add_material(Material m);

  // ---- time step --------------------------------------------------------------------------
  // The critical step of the smallest particle in a dense packing (stable_step.hpp).
  [[nodiscard]] double stable_dt() const;
  [[nodiscard]] double auto_dt() const { return config_.dt_safety * stable_dt(); }
  // Throws StepRefused (the limit, its formula and the automatic step) when dt ≤ 0 or above
  // stable_dt(); callers with a scene turn it into a located scene error (set_scene_dt, run.hpp).
  void set_dt(double dt);
  [[nodiscard]] double dt() const { return dt_; }

  // ---- stepping ---------------------------------------------------------------------------
  // Builds the neighbour list now if the next step would (the first step: its rebuild sorts a
  // large set into cell order), as LAMMPS's setup does before its timed loop. Optional: the
  // steps that follow have the same bits with or without it (bench_dem_race calls it before
  // its clock starts).
  void prepare();
  void step();
  void run_steps(long long n);
  // Steps while time() < t_stop − Δt/2 (the test a runner's `time ≥ t_next − Δt/2` action
  // makes), at most max_steps, and while healthy: what a loop of step() would do, in fewer
  // parallel regions when a team of threads runs it. Returns the steps run.
  long long run_until(double t_stop, long long max_steps);
  [[nodiscard]] double time() const { return time_; }
  void set_time(double t) { time_ = t; }

  // Blow-up state: empty while healthy.
  [[nodiscard]] const std::string& failure() const { return failure_; }
  [[nodiscard]] bool failed() const { return !failure_.empty(); }

  // ---- events -----------------------------------------------------------------------------
  void open_wall(const std::string& name);
  // Particles whose centre is in `region` get a new material with the given friction.
  std::size_t set_friction(const scene::Polygon& region, double mu_s, double mu_d);

  // ---- threads ----------------------------------------------------------------------------
  void set_threads(int threads) { config_.threads = threads; }
  [[nodiscard]] int threads_in_use() const; // parts the work is cut into (current count)
  // Threads that run those parts now (≤ threads_in_use(); the adaptive team's current choice).
  [[nodiscard]] int team_size() const;
  // Fixes the team size (1 … threads; results do not change with it) and stops adapting it;
  // 0: the full team, adaptive again when the configuration says so. For tests and benchmarks.
  void set_team(int k) {
    team_ = k;
    tuner_ = {};
    tuner_.fixed = k > 0;
  }
  // The adaptive team's view of the machine: a counter of idle CPU-seconds of the CPUs this
  // process may use (dem::idle_cpu_seconds, cpu_idle.hpp; NaN: unknown). With one, a probe of the
  // full team is made only when the other CPUs were idle for at least half of the time the team
  // would need (T − 1 CPUs) since the last decision: on a machine whose other cores are busy, a
  // probe can only stall (bench/RESULTS.md, "busy core"). Without one (the default, and for a
  // counter that reads NaN) every probe is made.
  // `free_now` (optional; dem::free_cpus_now): CPUs free at this instant besides the caller's, −1
  // unknown. Read once, before the first step: with T − 1 free the run starts on the full team
  // (probing one thread after the first window) instead of on one thread, which would need a
  // span of the idle counter (≥ 0.05 s) before its first probe of the full team.
  void set_idle_source(std::function<double()> source, std::function<int()> free_now = {}) {
    idle_source_ = std::move(source);
    free_now_ = std::move(free_now);
  }
  // The clock the adaptive team times its windows with (default: std::chrono::steady_clock; for
  // tests, which give each step the duration they choose).
  void set_team_clock(std::function<std::chrono::steady_clock::time_point()> clock) {
    team_clock_ = std::move(clock);
  }

  // ---- checkpoint / resume ----------------------------------------------------------------
  // Everything besides the particle arrays that a bit-for-bit continuation needs: time, step,
  // Δt, counters, materials table, boundary states (opened walls, vertices), structure states,
  // the Verlet lists with their per-pair and per-boundary contact history, Verlet reference
  // positions, reorder counter, energy accumulators. Versioned binary blob.
  [[nodiscard]] std::vector<std::byte> save_state() const;
  // Restores a state saved by save_state() on an engine built the same way (same walls and
  // structures added in the same order; particles are replaced by `particles`). Throws
  // std::runtime_error when the blob does not match this engine.
  void restore_state(Particles particles, std::span<const std::byte> state);
  // Contact history only (particle–particle pairs by stable id, and particle–feature), e.g. for
  // a packing checkpoint; load_contact_history() keeps the entries whose ids exist.
  [[nodiscard]] std::vector<std::byte> save_contact_history(bool with_boundaries = true) const;
  void load_contact_history(std::span<const std::byte> blob);
  // Memory held by the engine's containers (capacities) [bytes].
  struct MemoryUse {
    std::size_t particles = 0, contact_history = 0, neighbour_lists = 0, grid = 0, other = 0;
    [[nodiscard]] std::size_t total() const {
      return particles + contact_history + neighbour_lists + grid + other;
    }
  };
  [[nodiscard]] MemoryUse memory_use() const;

  // ---- access -----------------------------------------------------------------------------
  [[nodiscard]] Particles& particles() {
    friction_dirty_ = true; // the materials may change through it
    nl_.disp_valid = false; // and the positions
    return p_;
  }
  [[nodiscard]] const Particles& particles() const { return p_; }
  [[nodiscard]] const std::vector<StructureState>& structures() const { return bd_.structures; }
  [[nodiscard]] std::vector<StructureState>& structures() { return bd_.structures; }
  [[nodiscard]] const std::vector<Boundary>& boundaries() const { return bd_.list; }
  [[nodiscard]] int boundary_index(const std::string& name) const;
  [[nodiscard]] int structure_index(const std::string& name) const;
  [[nodiscard]] const EngineConfig& config() const { return config_; }
  [[nodiscard]] const EngineStats& stats() const { return stats_; }
  [[nodiscard]] const std::vector<Material>& materials() const { return config_.materials; }
  // Index of the particle with the given stable id (particles are reordered), or −1.
  [[nodiscard]] long index_of(std::uint32_t id) const;

  // Energy budget at the current state (computes the kinetic/potential/spring parts).
  [[nodiscard]] EnergyBudget energy() const;
  // Contacts touching now (for force chains, coordination, wall profiles): the pairs (unless
  // `pairs` is false), then the boundary contacts.
  void contacts(std::vector<ContactView>& out, bool pairs = true) const;
  // The particle pairs touching now (the pairs contacts() lists).
  [[nodiscard]] std::size_t pair_contact_count() const;
  // The particle pairs whose disks overlap at the current positions (|x_i − x_j| ≤ r_i + r_j),
  // whether or not the last force evaluation saw them touch: the pairs LAMMPS's compute
  // contact/atom counts. A pass over the neighbour list, no square roots.
  [[nodiscard]] std::size_t overlapping_pair_count() const;
  // The largest overlap ratio δ / min(r_i, r_j) of the contacts touching now (what contacts()
  // lists): pairs from the positions; boundary contacts from the normal force their history
  // recorded, through the law's inverse of its elastic force (δ = f_n / K_n for the linear
  // laws; the Hertz overlap for hertz-mindlin).
  [[nodiscard]] double largest_overlap_ratio() const;
  // Extra history values per contact of the law's sub-models (contact.hpp, ContactHistory).
  [[nodiscard]] std::size_t history_width() const { return xh_; }
  void boundary_views(std::vector<BoundaryView>& out) const;
  // Current world vertices of a boundary.
  void boundary_vertices(int b, std::vector<scene::Vec2>& out) const;

private:
  // Sets fx, fz, torque of every particle to its contact forces: each part zeroes and fills its
  // own range with the particle–particle forces, then adds its particles' wall and structure
  // contacts (boundary_range), on the thread that will integrate them.
  template <class Law> void contact_forces(const Law& law);
  // The steps of contact_forces with two parts or more (fp_.split), for one step and for the many
  // steps of one parallel region (team_steps): the step's sums reset (serial), the parts set up
  // (serial: the split per list, the halo offsets, the part sums), part t's pair forces and
  // boundary contacts, part u's halo sums (after every part's forces), whether no part has a
  // rebound event, and the parts' sums added in part order (serial).
  void reset_step_sums();
  std::size_t begin_parts();
  template <class Law> void part_forces(const Law& law, std::size_t t);
  void part_halos(std::size_t u);
  [[nodiscard]] bool parts_quiet() const;
  void end_parts();
  void finish_forces(const double* en, const std::uint32_t* fail);
  // Up to max_steps whole steps, while time_ < t_stop − Δt/2, in one parallel region of the full
  // team (no fork and join per step): returns the steps run; 0 when the step cannot run there
  // (then step() runs it). It stops before a step that needs a rebuild, after a failure, and when
  // the adaptive team changes.
  template <class Law> long long team_steps(const Law& law, long long max_steps, double t_stop);
  // check_rebuild's test on the integration's displacements, without the rebuild and without
  // changing anything (true too when they are not known: check_rebuild then decides).
  [[nodiscard]] bool rebuild_pending() const;
  [[nodiscard]] bool past_skin(double disp2_a, double disp2_b) const;
  // One part's boundary contacts: the sums it adds to the boundaries, structures and energies,
  // combined in part order after the parts (add_boundary_sums), so the result depends on the
  // part count only.
  struct BoundarySums {
    double e_friction = 0.0, e_damping = 0.0, e_normal = 0.0, e_shear = 0.0;
    std::vector<double> reaction; // x, z per boundary
    std::vector<double> soil;     // fx, fz, moment per structure
    std::vector<detail::ReboundEvent> events;
    std::size_t fail = ~std::size_t{0}; // first entry beyond max_overlap·r, and its overlap
    double fail_delta = 0.0;
  };
  // The boundary entries k0 … k1 − 1 (the particles of one part): forces into the particles,
  // everything else into s (reset first).
  template <class Law>
  void boundary_range(const Law& law, std::size_t k0, std::size_t k1, BoundarySums& s);
  void add_boundary_sums(); // the fp_.event_parts parts
  void compute_forces();
  // Applies this step's rebound impulses (ReboundEvent; in part order, then the boundaries'):
  // each contact's P ≥ 0 brings its approach to K v_n given the others' (projected Gauss–Seidel;
  // dem/contact/rebound.hpp, cundall-rebound), added to the forces as P/Δt; books the rebound
  // energy.
  void apply_rebounds();
  void integrate();
  void update_structures();
  void rebuild();
  void reorder();
  void update_boundary_vertices();
  void check_rebuild();
  void compute_mass(std::uint32_t i);
  Boundary new_boundary(const std::string& name, const std::vector<scene::Vec2>& points,
                        std::optional<double> mu_s, std::optional<double> mu_d);
  using ForceTarget = detail::ForceTarget;
  static constexpr std::size_t kMaxParts = 64;
  template <class Law>
  void pair_range(const Law& law, std::size_t i0, std::size_t i1, const ForceTarget& out,
                  double* energies, std::uint32_t* fail_pair);
  using ReboundModel = contact::ContactModel<contact::CundallRebound, contact::NoRolling>;
  void pair_range_rebound(const ReboundModel& law, std::size_t i0, std::size_t i1,
                          const ForceTarget& out, double* energies, std::uint32_t* fail_pair);
  // One part's integration: its external work and damping loss, its first non-finite particle,
  // and the two largest squared displacements since the last rebuild (the next step's rebuild
  // test); integrate() adds them up in part order.
  struct IntegratedPart {
    static constexpr std::size_t kNone = ~std::size_t{0};
    double work = 0.0, damping = 0.0;
    std::size_t bad = kNone;
    double top_a = 0.0, top_b = 0.0;
  };
  void integrate_range(std::size_t i0, std::size_t i1, double ax_body, double az_body,
                       IntegratedPart& out);
  [[nodiscard]] std::pair<double, double> body_acceleration() const; // shaking (x, z) [m/s²]
  // Inside a parallel region: (this thread's number, team size).
  static std::pair<std::size_t, std::size_t> team_member();
  void tune_team(); // after each step: measures, and switches the adaptive team
  void start_team(std::chrono::steady_clock::time_point now); // before the first adaptive step

  // Adaptive team: windows of whole steps are timed with the current team; now and then one
  // window runs with the other choice (1 thread or all), and the faster one is kept.
  int team_ = 0; // 0: the full team
  struct TeamTuner {
    bool fixed = false, started = false, probing = false;
    std::chrono::steady_clock::time_point t0{};
    long steps = 0, window = 8;
    double rebuild_s = 0; // the neighbour rebuilds' time in this window (left out of its pace)
    int current = 0;      // team size outside probes (0: full)
    double current_per_step = 0; // seconds per step of the last window with `current`
    int until_probe = 4, probe_every = 4;
    std::chrono::steady_clock::time_point idle_t{}; // last reading of the idle counter
    double idle_s = std::numeric_limits<double>::quiet_NaN();
    // When the last run_until returned: the caller's time until the next one (snapshots, probes,
    // checkpoints) is not the team's and is left out of the window (resume_team_clock).
    std::optional<std::chrono::steady_clock::time_point> paused_at;
  } tuner_;
  // run_until's bounds: the window's clock stops when it returns and goes on when it is called
  // again, so that a window spanning a snapshot does not read as a slow team.
  void pause_team_clock();
  void resume_team_clock();
  std::function<double()> idle_source_;
  std::function<int()> free_now_;
  std::function<std::chrono::steady_clock::time_point()> team_clock_;
  // The adaptive team's clock: team_clock_ when set, else std::chrono::steady_clock.
  [[nodiscard]] std::chrono::steady_clock::time_point team_now() const {
    return team_clock_ ? team_clock_() : std::chrono::steady_clock::now();
  }
  // Whether the other CPUs were idle enough since the last reading for a probe of the full team:
  // 1 yes (or unknown), 0 no, −1 too short a span to tell.
  int others_idle(std::chrono::steady_clock::time_point now);

  EngineConfig config_;
  std::size_t xh_ = 0; // the law's extra history values per contact (its kHistory)
  Particles p_;
  double dt_ = 0.0, time_ = 0.0;
  std::string failure_;
  EngineStats stats_;

  double r_min_ = 0.0, r_max_ = 0.0, m_min_ = 0.0;
  std::vector<std::uint32_t> id_to_index_;
  std::uint32_t next_id_ = 0;

  // ---- the parts the engine is made of: their data (the methods above act on them)
  struct Feature {
    std::uint32_t boundary, v0, v1;    // v1 == v0: a vertex feature
    std::int32_t adj0 = -1, adj1 = -1; // vertex features: adjacent segment features
  };
  // The boundaries: walls and structure faces as vertex arrays (local = reference, world =
  // current) and features (segments and vertices), and the structures' rigid-body states.
  struct Boundaries {
    std::vector<Boundary> list;
    std::vector<double> vx, vz, vx0, vz0; // world / reference vertices
    std::vector<Feature> features;
    std::vector<StructureState> structures;
  } bd_;
  // The neighbour list (engine_neighbours.cpp): Verlet pairs in CSR (owner i < partner j) with a
  // contact history per entry, the boundary candidates, and what the rebuild test compares.
  struct NeighbourList {
    std::vector<std::uint32_t> start, j;
    std::vector<ContactHistory> hist;
    std::vector<double> xh;           // xh_ extra history values per entry (empty when xh_ = 0)
    std::vector<std::uint32_t> owner; // owner of each entry (the blocked pair loop's flat walk)
    // Boundary candidates: (particle, feature) sorted by particle, with history.
    std::vector<std::uint32_t> bnd_i, bnd_f;
    std::vector<ContactHistory> bnd_hist;
    std::vector<double> bnd_xh;           // xh_ per entry, as xh
    std::vector<double> x_ref, z_ref;     // particle positions at the last rebuild
    std::vector<double> bvx_ref, bvz_ref; // boundary vertices at the last rebuild
    // The largest two squared displacements since the rebuild, from the integration (valid until
    // the positions or x_ref change otherwise; check_rebuild then passes over them itself).
    double disp_a = 0.0, disp_b = 0.0;
    bool disp_valid = false;
    double skin = 0.0;
    bool need_rebuild = true;
    long long rebuilds_since_reorder = 0;
    std::uint64_t version = 0; // counts the lists (fp_.version: the one the parts are for)
    // Cell grid buffers of the rebuild, kept between rebuilds.
    std::vector<std::uint32_t> cell_of, cell_start, cell_items;
    // The rebuild's boundary candidates per part (2 threads or more), kept for their capacity.
    std::vector<std::vector<std::uint32_t>> cand_bi, cand_bf;
  } nl_;
  // The energy ledger (EnergyBudget): dissipated and external work so far, the springs of the
  // last step, the potential energy's reference, and what removed particles carried out.
  struct EnergyLedger {
    double friction = 0.0, damping = 0.0, rebound = 0.0, external = 0.0;
    double normal = 0.0, shear = 0.0; // spring energies, last step
    double pe_ref = 0.0;
    double left = 0.0, pe_left = 0.0; // removed particles: their kinetic energy and m g z
    bool pe_ref_set = false;
  } en_;

  void set_owners(); // after every change of nl_.start
  // A pair's extra history when its owner and partner swap (the law's ContactModel::flip_owner).
  void flip_owner(double* extra) const {
    std::visit([extra](const auto& law) { law.flip_owner(extra); }, config_.law);
  }
  void first_step_setup();                        // Δt and the potential energy's reference, once
  static constexpr std::size_t kPartEnergies = 4; // friction, damping, normal and shear springs
  // The force loop's parts (engine_forces.cpp): the particles split into parts (one per thread),
  // each with its halo, energies, failures, boundary contacts and rebound events, combined in part
  // order so that results depend on the part count only.
  struct ForceParts {
    // Halo force buffers (fx, fz, torque of the partners beyond each part's range), the parts'
    // owner ranges, and the end of each part's halo (one past its largest partner), computed for
    // the list of version `version` (nl_.version counts the lists).
    std::vector<double> tbuf;
    std::vector<std::size_t> halo_off; // part t's halo: tbuf[halo_off[t]] …, 3 arrays
    std::array<double, kPartEnergies * kMaxParts> en{}; // per part, this step
    std::array<std::uint32_t, 2 * kMaxParts> fail{};    // per part: first pair past the limit
    // Rebound events of this step: one list per part of the pair loop (parts 0 … event_parts − 1),
    // then the boundaries'; the velocity changes of the particles they touch (apply_rebounds).
    std::vector<std::vector<detail::ReboundEvent>> rebound_events;
    std::size_t event_parts = 0; // the parts of this step's contacts (pairs and boundaries)
    std::array<IntegratedPart, kMaxParts> integrated;
    std::size_t integrated_parts = 0; // > 0: this step's parts were integrated in the force loop
    // Boundary contacts per part: part t has the entries bnd_split[t] … bnd_split[t + 1] − 1
    // (nl_.bnd_i is sorted by particle), and its sums (events included) in bnd_sums[t].
    std::vector<std::size_t> bnd_split;
    std::vector<BoundarySums> bnd_sums;
    std::vector<detail::ReboundEvent> rebound_all; // all of them, in that order
    std::vector<double> rebound_p;                 // their impulses [N·s]
    std::vector<std::uint32_t> rebound_touched, rebound_count;
    std::vector<std::size_t> rebound_slot; // per event: its i's and j's index in rebound_touched
    std::vector<double> rebound_dv;
    // halo_from[t]: part t's first owner with a partner beyond the part (before it: no halo).
    std::vector<std::size_t> split, halo_end, halo_from;
    std::uint64_t version = ~0ull; // the list version (nl_.version) the parts are for
  } fp_;
  // Friction of the pairs: uniform when every material in use has the same μ_s, μ_d (then the
  // pair loops take them as constants instead of the weaker of the pair's two materials: the
  // same values). Recomputed before the forces after a change of materials or of particles.
  bool friction_dirty_ = true, friction_uniform_ = true;
  double friction_mus_ = 0.0, friction_mud_ = 0.0;
  void update_pair_friction();
  void boundary_candidates(std::size_t i0, std::size_t i1, std::vector<std::uint32_t>& ni,
                           std::vector<std::uint32_t>& nf) const;
};

} // namespace demfem::dem
