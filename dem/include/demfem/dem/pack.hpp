// Packing: the initial granular assembly of a scene. Particles are drawn from the scene's radius
// distribution with the scene seed, placed without overlap by random sequential addition in the
// fill polygon (and, when it is too small to hold them loosely, in copies of it stacked above),
// then deposited under gravity until they come to rest. The result is cached as a checkpoint
// keyed by everything that shapes it, so every variant of a scene starts from the same assembly
// and a rerun skips the deposition.
//
// Deposition (decided once for all scenes, documented in cases/README.md):
//   * the scene's walls act (openings stay closed: an opening is an event of the run);
//   * the scene's structures act as fixed obstacles where the scene places them (their loads,
//     motions and dead weight are not applied), so soil settles around an embedded pile or
//     foundation exactly as the run will find it;
//   * the edges of the fill polygon that do not face upwards (outward normal n_z ≤ 0.5) and do
//     not coincide with a scene wall or structure act as a temporary container, removed when the
//     run starts, so a mass deposited on a slope (Ontake) keeps its section's shape; when copies
//     are stacked above the fill, vertical walls at the fill's left and right extent guide them;
//   * friction and contact law are the scene's; packing.damping adds global damping (ratio of
//     critical for the mean particle) during deposition only.
// It stops when kinetic energy < packing.ke_ratio × potential energy released, or at
// packing.max_time.
//
// Target density (packing.target = { porosity = n } or { void_ratio = e }): reached by
// deposition with a raised (or lowered) interparticle friction that is then reset — the standard
// way to make loose or dense DEM specimens under gravity. Both friction coefficients are scaled
// by one factor s (μ_s' = s μ_s, μ_D' = s μ_D); after the deposition at s the scene's friction is
// restored and the bed settles again (at least 20 √(2 r_max / g), then until KE < ke_ratio × PE
// released), and the porosity is measured on the settled bed. s is bracketed (1, then doubled up
// to 16 for looser targets, stopping early when a doubling closes less than a tenth of the gap to
// the target; ½, then 0, i.e. frictionless deposition, for denser ones) and bisected until
// |n − target| ≤ tolerance (at most 10 depositions); the packing nearest to the target is kept.
// Deterministic: every trial starts from the same placement.
//
// Porosity (measure_packing): 1 − solid area / available area in the measurement window = the
// fill polygon between its lowest point and the bed surface less one largest diameter (surface =
// the 10th percentile of the tops of columns 2 r_max wide), less the structures' area there;
// disks are cut exactly at the window's top and bottom. Coordination number Z = 2 C / N over all
// particles, C the particle–particle contacts (overlap > 0).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "demfem/dem/state.hpp"
#include "demfem/scene/progress.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::dem {

struct EngineConfig; // engine.hpp

// Portable uniform random numbers: std::mt19937_64 is specified bit-exactly by the standard; the
// mapping to [0, 1) is ours (53 high bits), unlike std::uniform_real_distribution whose output
// differs between standard libraries.
class PortableRandom {
public:
  explicit PortableRandom(std::uint64_t seed);
  double uniform();                     // [0, 1)
  double uniform(double lo, double hi); // [lo, hi)

private:
  std::mt19937_64 engine_;
};

// `count` radii from the distribution (uniform in r; equal; tabulated histogram: radius r_k with
// relative frequency w_k), in the order they are placed. Deterministic for a given seed.
[[nodiscard]] std::vector<double> draw_radii(const scene::RadiusDistribution& d, int count,
                                             std::uint64_t seed);

// 64-bit FNV-1a digest of everything that shapes the packing: fill polygon, count, radius
// distribution, density, thickness, contact law and its parameters, friction, gravity, walls,
// structure outlines, seed and the packing settings. Hex string of 16 digits.
// The key also carries the engine's fingerprint (engine_fingerprint), so a packing deposited by
// an engine that rounds differently is not reused: it would not be the packing this engine makes.
[[nodiscard]] std::string packing_key(const scene::Scene& scene);
// The same with a given engine fingerprint (tests).
[[nodiscard]] std::string packing_key(const scene::Scene& scene, const std::string& engine);

// What the engine does, bit for bit: the FNV-1a digest of the positions and contact history of a
// small bed (150 disks, friction, rebound, walls, ≈ 3,300 steps with many neighbour rebuilds)
// deposited by this build, and of its positions after 0.2 s more of the run's step (no damping,
// shaking). Any change that moves the DEM by round-off (summation order, the
// neighbour list's rebuild rule or skin, the pair kernel) changes it; a change that leaves every
// bit alone does not. It enters the cache keys of packings and, through them, of calibrations,
// so a checkout never reuses a cache an older engine wrote. Computed once per process (≈ 0.04
// s); 16 hex digits.
[[nodiscard]] const std::string& engine_fingerprint();
// Computes it afresh; `tweak` changes the engine's configuration first (tests: a different skin
// must give a different fingerprint).
[[nodiscard]] std::uint64_t
compute_engine_fingerprint(const std::function<void(EngineConfig&)>& tweak = {});

// Where the packing of `scene` is cached: packing.cache (relative paths are taken relative to the
// scene file's directory) or <out_dir>/packing; file name packing-<key>.ckpt.
[[nodiscard]] std::filesystem::path packing_path(const scene::Scene& scene,
                                                 const std::filesystem::path& out_dir);

// Density and contacts of a packing (see the header comment for the window).
struct PackingMeasure {
  double porosity = 0.0;              // n = void area / total area in the window
  double void_ratio = 0.0;            // e = void area / solid area = n / (1 − n) (2D)
  double coordination = 0.0;          // Z = 2 C / N, particle–particle contacts
  double rattlers = 0.0;              // fraction of particles without a particle contact
  double z_bottom = 0.0, z_top = 0.0; // the measurement window [m]
};
[[nodiscard]] PackingMeasure measure_packing(const scene::Scene& scene, const Particles& p);

// The particle pairs that overlap (|x_i − x_j| < r_i + r_j), i < j, ordered by i then j, removed
// particles left out: what a test of every pair gives, found on a cell grid 2 r_max wide (O(N)
// instead of O(N²): the all-pairs loop of the final figures took 25 s of a 10⁵-disk run).
[[nodiscard]] std::vector<std::pair<std::uint32_t, std::uint32_t>>
overlapping_pairs(const Particles& p);

struct PackResult {
  // At rest, velocities zeroed, ids in placement order: 0…count−1, less the `carved` particles
  // removed from embedded structures' outlines (pack.cpp, carved()).
  Particles particles;
  std::filesystem::path path; // the checkpoint
  std::string key;
  bool from_cache = false;
  double deposition_time = 0.0; // simulated [s]
  long long steps = 0;
  double ke_ratio = 0.0; // kinetic / released potential energy at the end
  double wall_seconds = 0.0;
  int layers = 1;           // copies of the fill used for placement
  bool converged = false;   // ke_ratio reached before max_time
  double surface_max = 0.0; // highest particle top after deposition [m]
  // Particle–particle contact history at the end of deposition (shear springs, sliding and bond
  // flags; Engine::save_contact_history without boundaries, whose features differ between the
  // deposition and the run). Empty for explicit particles and packings cached without it.
  std::vector<std::byte> contact_history;
  PackingMeasure measure;      // of the packing as returned
  double friction_scale = 1.0; // s of the deposition kept (1 without a target)
  int trials = 1;              // depositions made to reach the target
  bool target_met = true;      // |porosity − target| ≤ tolerance (true without a target)
  std::size_t carved = 0;      // particles removed where embedded structures stand
  // Per scene structure (empty: none seated): the vertical offset [m] at which an embedded,
  // vertically fixed structure rests on the bed after seating (pack.cpp); the run places it there.
  std::vector<double> seat_dz;
  // Per scene structure (empty: none turned): the rotation [rad, counter-clockwise, about the
  // pivot] at which a seated structure the run leaves free to rotate came to rest on the bed; the
  // run places it so (scene::rotated), so it starts in moment equilibrium.
  std::vector<double> seat_rot;
  double seat_load =
      0.0; // the bed's reaction / the structure's weight, at rest on it (packing end)
};

// Writes the packing's statistics and measure as JSON (beside a checkpoint, or into a run).
void write_packing_json(const PackResult& r, const scene::Scene& scene,
                        const std::filesystem::path& path);

// Places the particles without overlap (no deposition). Throws scene::SceneError (key
// soil.dem.fill) when they cannot be placed.
[[nodiscard]] Particles place_particles(const scene::Scene& scene, int* layers = nullptr);

// Always deposits (ignores the cache) and writes the checkpoint.
PackResult pack(const scene::Scene& scene, const std::filesystem::path& out_dir,
                const scene::ProgressFn& progress = {});

// The scene's explicit particles (soil.dem.particles) when given; otherwise the cached packing
// when its checkpoint exists and is valid; otherwise pack().
PackResult pack_or_load(const scene::Scene& scene, const std::filesystem::path& out_dir,
                        const scene::ProgressFn& progress = {});

} // namespace demfem::dem
