// `demfem calibrate`: continuum parameters from DEM element tests on specimens
// made by the scene's own packing procedure and contact parameters, and the state of the scene's
// deposited bed.
//
//   * Specimen: the scene's [soil.dem] (radius distribution, contact law and stiffnesses, μ_s/μ_D,
//     rebound, density, seed, packing settings incl. a porosity target) deposited under gravity
//     by dem::pack into a box W × 1.5 W holding `particles` disks (default 1,000); `specimens`
//     such realisations (default 3; specimen k deposited with seed + k·1,000,003), because one
//     1,000-disk specimen fixes φ only to ≈ ±1.5° and the φ–c split not at all (cases/README.md,
//     "Realisation spread of the calibration").
//   * Biaxial compression of every specimen at σ_c = ρ_b g z for z = H/10, H/4, H/2, H (H: the
//     bed's height, ρ_b its bulk density; H/10 so that the envelope is measured, not extrapolated,
//     in the top of the bed): isotropic consolidation, then axial compression at a quasi-static
//     rate (inertial number 1e-3) to 15 % axial strain with σ_c held on the lateral platens
//     (calibrate_element). Per test: E (initial tangent and secant at 50 % of the peak deviator),
//     ν, φ_peak, φ_cv (mean over the last quarter of the test), ψ at the peak; over all tests:
//     Mohr–Coulomb fit of the peak states (φ, c), and the same fit per specimen for the spread.
//   * Cyclic biaxial of every specimen at σ_c(H/2): secant shear modulus G, damping ratio ξ and
//     in-plane ν' against amplitude; the smallest amplitude again at σ_c(H/10), so that the
//     continuum's modulus follows the bed's confinement, E ∝ p^n (n = ln(G0(H/2)/G0(H/10)) /
//     ln 5; Janbu 1963, Hardin & Richart 1963).
//   * The continuum's E: the small-strain E0 = 2 G0 (1 + ν) of the cyclic test (the scenes load
//     the soil cyclically; the monotonic E50 is reported beside it), or E50 at mid-depth when
//     the cyclic test is skipped; ν from the biaxial test at mid-depth (50 % of the peak).
//   * Bed: K0 = σ_xx/σ_zz from the Love–Weber stress of the deposited packing away from walls and
//     structures; bulk density ρ_s (1 − n) from dem::measure_packing; and the ground surface at
//     which a continuum of that density holds the DEM's soil mass (matched height and mass).
//
// 2D → plane strain: the DEM is a 2D assembly; its in-plane moduli E', ν' (Δσ_xx = 0) equal the
// plane-strain ones of the continuum, E' = E/(1 − ν²), ν' = ν/(1 − ν) (Timoshenko & Goodier §8),
// so the continuum gets ν = ν'/(1 + ν'), E = E'(1 − ν²).
//
// Cached as <cache>/calibration-<key>.json, the key a digest of everything that shapes it (the
// packing key of the scene and of the specimen, the options); a second call reads it back.
#pragma once

#include <filesystem>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "demfem/scene/progress.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::calibrate {

struct CalibrateOptions {
  std::filesystem::path out_dir;   // calibration.json, calibration.toml, figures/ ("" = none)
  std::filesystem::path cache_dir; // "" = the scene's packing.cache, else <out_dir>/cache
  int particles = 1000;            // specimen size
  int specimens = 3;               // specimen realisations, each tested at every confinement
  std::vector<double> depth_fractions{0.1, 0.25, 0.5, 1.0}; // confinements σ_c = ρ_b g (f·H)
  double max_axial_strain = 0.15;
  double inertial_number = 1e-3;
  bool cyclic = true;
  std::vector<double> cyclic_amplitudes{1e-4, 3e-4, 1e-3, 3e-3}; // axial strain amplitudes
  // The smallest amplitude again at σ_c = ρ_b g (f·H), f = this (0: not), for the modulus's
  // stress exponent n of E ∝ p^n between there and mid-depth
  double cyclic_shallow_fraction = 0.1;
  bool figures = true;
  scene::ProgressFn progress; // may be empty
};

struct BiaxialCurve {
  int specimen = 0;                  // which realisation (0 … specimens − 1)
  double depth = 0.0, sigma_c = 0.0; // [m], [Pa]
  double porosity = 0.0;             // after consolidation
  double strain_rate = 0.0;          // [1/s]
  double e_small = 0.0;              // in-plane E' initial tangent [Pa]
  double e50 = 0.0;                  // in-plane E' secant at 50 % of the peak deviator [Pa]
  double nu_inplane = 0.0;           // ν' = −ε_xx/ε_zz at that point
  double phi_peak = 0.0, phi_cv = 0.0, psi = 0.0; // [deg]
  double s_peak = 0.0, t_peak = 0.0; // (σ1+σ3)/2, (σ1−σ3)/2 at the peak stress ratio [Pa]
  double strain_at_peak = 0.0;
  double end_dilatancy = 0.0; // dε_v/dε_a over the last quarter (≈ 0 at critical state)
  double dilation = 0.0;      // volumetric strain from the densest point to the end (≥ 0)
  std::string failure;
  // samples: ε_a, ε_xx, σ_zz, σ_xx (compression positive)
  std::vector<double> ea, el, sa, sl;
};

struct CyclicPoint {
  double gamma = 0.0; // shear strain amplitude γ = ε_zz − ε_xx
  double g = 0.0;     // secant shear modulus [Pa]
  double xi = 0.0;    // damping ratio
  double nu = std::numeric_limits<double>::quiet_NaN(); // in-plane ν' = −ε_xx/ε_zz of the cycle
};

struct Calibration {
  std::string key;
  std::string scene_label;
  bool from_cache = false;
  double wall_seconds = 0.0;
  // bed
  double bed_bottom = 0.0, bed_height = 0.0; // [m]
  double surface = 0.0;                      // mass-matched ground surface [m]
  double surface_top_mean = 0.0;             // mean of the column tops (2 r_max wide) [m]
  double porosity = 0.0, bulk_density = 0.0, coordination = 0.0;
  double soil_mass = 0.0, continuum_mass = 0.0; // DEM particles; ρ_b × continuum soil [kg/m]
  double k0 = 0.0;
  std::vector<std::pair<double, double>> k0_profile; // (depth below surface [m], K)
  // Embedded structures the packing seated on the bed: (name, vertical offset [m]).
  std::vector<std::pair<std::string, double>> seat_dz;
  // specimen and element tests
  int particles = 0;
  int specimens = 1;
  double specimen_porosity = 0.0;            // as deposited, mean over the specimens
  std::vector<unsigned long> specimen_seeds; // packing seed of each specimen
  std::vector<BiaxialCurve> tests;           // by confinement, then by specimen
  double phi_fit = 0.0, cohesion_fit = 0.0;  // Mohr–Coulomb fit of all peaks [deg], [Pa]
  // The same fit on each specimen's peaks alone (φ [deg], c [Pa]): the realisation spread.
  std::vector<std::pair<double, double>> specimen_fits;
  double phi_cv = 0.0, psi = 0.0;        // means over the tests [deg]
  double affine_e = 0.0, affine_g = 0.0; // affine (upper-bound) in-plane E', G [Pa]
  double cyclic_sigma = 0.0;
  std::vector<CyclicPoint> cyclic; // by amplitude: the means over the specimens
  std::vector<std::vector<CyclicPoint>> cyclic_per_specimen; // each specimen's cycles
  // The smallest amplitude at the shallow confinement (CalibrateOptions::cyclic_shallow_fraction),
  // each specimen's; 0 / empty when not run
  double cyclic_shallow_sigma = 0.0;
  std::vector<CyclicPoint> cyclic_shallow;
  // Stress-dependent modulus E = young (p/p_ref)^n: n from G0 at the two confinements,
  // p_ref = cyclic_sigma (where young's G0 is measured); n = 0: uniform (no shallow test)
  double modulus_exponent = 0.0, modulus_reference_stress = 0.0;
  // what the continuum takes (plane strain)
  double young = 0.0, poisson = 0.0, cohesion = 0.0; // [Pa], –, [Pa]
  // φ and ψ in degrees (the scene's friction_angle and dilation_angle are radians)
  double friction_angle_deg = 0.0, dilation_angle_deg = 0.0;
  // dilatancy cut-off: mean of the tests' `dilation` (NaN: none measured, or an older file)
  double dilation_cutoff = std::numeric_limits<double>::quiet_NaN();
  std::string young_source;   // which test and measure E comes from
  double young_small = 0.0;   // 2 G0 (1 + ν): G0 of the smallest cyclic amplitude [Pa]
  double young_e50 = 0.0;     // E50 (plane strain) at mid-depth when E is E0 [Pa]
  std::string poisson_source; // which test and measure ν comes from
  // ν of the biaxial tests at mid-depth (50 % of the peak) when ν is the cyclic test's (NaN: not)
  double poisson_e50 = std::numeric_limits<double>::quiet_NaN();
};

// Digest of everything that shapes the calibration (16 hex digits).
// The element-test specimen k: the scene's [soil.dem] in a box W × 1.5 W of `n` disks, deposited
// by the scene's packing procedure (its walls are the box's base and sides) at the seed of
// specimen k (the scene's, then + 1,000,003 k), its packing cached in `cache`.
[[nodiscard]] scene::Scene specimen_scene(const scene::Scene& scene, int n,
                                          const std::filesystem::path& cache, int k = 0);
[[nodiscard]] std::string calibration_key(const scene::Scene& scene, const CalibrateOptions& o);
[[nodiscard]] std::filesystem::path calibration_cache_dir(const scene::Scene& scene,
                                                          const CalibrateOptions& o);

// Always runs the tests (and refreshes the cache). Throws scene::SceneError for a scene without
// a packed [soil.dem].
Calibration calibrate(const scene::Scene& scene, const CalibrateOptions& o);
// The cached calibration when it exists, else calibrate().
Calibration load_or_calibrate(const scene::Scene& scene, const CalibrateOptions& o);

// A calibration.json written by write_calibration (e.g. a run directory's); throws on a missing or
// malformed file.
[[nodiscard]] Calibration read_calibration(const std::filesystem::path& json_file);

// calibration.json, calibration.toml and (with figures) figures/*.png in `dir`; returns the
// figure paths written and problems met.
struct CalibrationFiles {
  std::vector<std::filesystem::path> written;
  std::vector<std::string> problems;
};
CalibrationFiles write_calibration(const Calibration& c, const std::filesystem::path& dir,
                                   bool figures);
// The [soil.continuum] block with provenance comments.
[[nodiscard]] std::string continuum_block(const Calibration& c);
// Each specimen's envelope (Calibration::specimen_fits) as "14.8° / 0.67 kPa, …": the TOML
// comment and the report's calibration paragraph.
[[nodiscard]] std::string specimen_fits_text(const std::vector<std::pair<double, double>>& fits);

// [soil.continuum] calibrate = "dem": sets every calibrated key the scene does not state
// (young, poisson, friction_angle, cohesion, dilation_angle, density, k0, surface) and records
// the provenance of each; returns one line per key.
std::vector<std::string> apply_calibration(scene::Scene& scene, const Calibration& c);

} // namespace demfem::calibrate
