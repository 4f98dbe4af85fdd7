// What the two models of a comparison are, for the report ("whatever still
// differs is listed in the report"): one row per aspect (soil model, surface and mass, initial
// stress, boundaries, damping, excitation, structure placement, time integration, resolution),
// with what the DEM does, what the continuum does, the consequence, and whether the two are
// matched. Built from the resolved scene (after calibrate = "dem" is applied), from what each
// solver recorded about its run (<run>/run_<solver>.json, written by the app) and from the
// calibration and packing the run used (<run>/calibration/calibration.json, <run>/dem/
// packing.json) — never from fixed prose: each row states what the code does for this scene
// (continuum boundaries: continuum/run/run.cpp and fem.hpp; DEM walls: dem/src/engine.cpp).
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "demfem/scene/scene.hpp"

namespace demfem::compare {

// One solver's run as the app recorded it (<run>/run_<solver>.json; beside the solver's folder,
// which stays byte-identical between an interrupted-and-resumed run and an uninterrupted one).
struct SolverRun {
  bool present = false; // the file exists
  std::string solver;   // "dem" | "continuum"
  bool ok = false;
  std::string message;         // failure cause or summary
  std::string note;            // e.g. stopped at the small-strain limit
  double solver_seconds = 0.0; // the solver's own wall time [s]
  double total_seconds = 0.0;  // with packing, set-up and figures [s]
  long long steps = 0;
  double dt = 0.0; // [s]
  double simulated_time = 0.0;
  int threads = 0;
  // DEM
  std::size_t particles = 0;
  // continuum
  std::size_t dofs = 0, cells = 0;
  int refinement = -1, degree = -1;
  std::string integrator;
  long long substeps = 0;
  double h_min = 0.0, h_max = 0.0;
  std::vector<std::pair<std::string, double>> seated; // (structure, settlement [m])
  std::string finished_utc;
};

[[nodiscard]] std::filesystem::path solver_run_file(const std::filesystem::path& run_dir,
                                                    const std::string& solver);
void write_solver_run(const std::filesystem::path& run_dir, const SolverRun& r);
[[nodiscard]] SolverRun read_solver_run(const std::filesystem::path& run_dir,
                                        const std::string& solver);

// What the run directory says about both models beyond the scene.
struct ModelFacts {
  SolverRun dem, continuum;
  // <run>/dem/packing.json: the deposited bed
  bool packing = false;
  double packing_porosity = 0.0;
  std::vector<std::pair<std::string, double>> dem_seat_dz; // structure, offset [m]
  // <run>/calibration/calibration.json
  bool calibration = false;
  std::string calibration_key;
  double cal_wall_seconds = 0.0;
  double cal_surface = 0.0, cal_surface_top_mean = 0.0, cal_bulk_density = 0.0, cal_porosity = 0.0,
         cal_k0 = 0.0, cal_soil_mass = 0.0, cal_continuum_mass = 0.0;
  std::vector<std::pair<std::string, double>> cal_seat_dz;
  double cal_cyclic_sigma = 0.0;
  struct Loop {
    double gamma = 0.0, g = 0.0, xi = 0.0;
  };
  std::vector<Loop> cal_cyclic;
  double cal_phi_fit = 0.0, cal_cohesion_fit = 0.0, cal_phi_cv = 0.0, cal_psi = 0.0;
  double cal_affine_e = 0.0, cal_affine_g = 0.0;
  std::string cal_young_source;
  double cal_young_small = 0.0, cal_young_e50 = 0.0;
  int cal_particles = 0, cal_specimens = 1;
  std::vector<std::pair<double, double>> cal_specimen_fits; // each specimen's φ [deg], c [Pa]
  // the coarse-graining support radius the report used [m] (0: not computed)
  double kernel_width = 0.0;
};

[[nodiscard]] ModelFacts read_model_facts(const std::filesystem::path& run_dir);

struct DiffRow {
  std::string aspect;
  std::string dem;
  std::string continuum;
  std::string consequence;
  bool matched = false;
};

// The "what differs between the two models" rows for this scene and run.
[[nodiscard]] std::vector<DiffRow> model_differences(const scene::Scene& scene,
                                                     const ModelFacts& facts);

struct ParamRow {
  std::string model; // "DEM" | "continuum"
  std::string name;  // scene key
  std::string value;
  std::string provenance; // stated in the scene / calibrated from the DEM (how) / default
};

// Both models' parameters with where each value came from.
[[nodiscard]] std::vector<ParamRow> model_parameters(const scene::Scene& scene,
                                                     const ModelFacts& facts);

// Mean disk diameter of the scene's radius distribution (number mean) [m]; 0 without [soil.dem].
[[nodiscard]] double mean_diameter(const scene::DemSoil& d);

} // namespace demfem::compare
