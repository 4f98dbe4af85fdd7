// The run-directory contract: the files both solvers write and the comparison reads, each file's
// columns and their units. Every name a writer or a reader uses comes from here.
//
// A time series is a CSV (csv.hpp) whose first column is `time [s]`; the other columns are
// "<quantity> [unit]" or, per structure, wall or bin, "<owner>.<quantity> [unit]". Signs:
//   settlement      downward positive: −z displacement of the structure's pivot
//   rotation        counter-clockwise positive (the paper's foundation θ is clockwise: θ =
//   −rotation) moment, force_x, force_z    the soil's reaction on the structure (moment about the
//   pivot) thrust          the soil force along the normal of the wall's chord pointing out of the
//   soil
//                   (scene::thrust_normal): > 0 when the soil presses on the wall
// A row's structure pose is the one its forces were computed at.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace demfem::output {

// One column of a time series: its quantity, unit and meaning.
struct Column {
  std::string_view name;
  std::string_view unit;
  std::string_view meaning;
};

// "name [unit]" and "owner.name [unit]": the header cells as written.
[[nodiscard]] std::string heading(const Column& c);
[[nodiscard]] std::string heading(std::string_view owner, const Column& c);
// "owner.name": a column looked up without its unit (CsvTable::find).
[[nodiscard]] std::string key(std::string_view owner, const Column& c);

// ---- directories of a run directory ------------------------------------------------------------
namespace dir {
inline constexpr std::string_view dem = "dem";             // the DEM run's files
inline constexpr std::string_view continuum = "continuum"; // the continuum run's files
inline constexpr std::string_view figures = "figures";     // the run's figures
inline constexpr std::string_view vtk = "vtk";             // dem/vtk: the .vtp snapshots
} // namespace dir

// ---- files ------------------------------------------------------------------------------------
namespace file {
// time series, both solvers unless said otherwise
inline constexpr std::string_view energy = "energy.csv"; // DEM
inline constexpr std::string_view structures = "structures.csv";
inline constexpr std::string_view walls = "walls.csv";
inline constexpr std::string_view surface = "surface.csv";           // DEM
inline constexpr std::string_view loci = "loci.csv";                 // DEM
inline constexpr std::string_view coordination = "coordination.csv"; // DEM
[[nodiscard]] std::string pressure(std::string_view target);         // "pressure_<target>.csv"
// the continuum's other records
inline constexpr std::string_view steps = "steps.csv";
inline constexpr std::string_view surface_profile = "surface_profile.csv";
inline constexpr std::string_view continuum_pvd = "continuum.pvd";
inline constexpr std::string_view continuum_basename = "continuum"; // continuum_<k>.pvtu, .vtu
// the DEM's other records
inline constexpr std::string_view packing = "packing.json";
inline constexpr std::string_view energy_budget = "energy_budget.json";
inline constexpr std::string_view checkpoint = "checkpoint.ckpt";
inline constexpr std::string_view final_state = "final.ckpt";
inline constexpr std::string_view particles_pvd = "particles.pvd";
inline constexpr std::string_view boundaries_pvd = "boundaries.pvd";
inline constexpr std::string_view force_chains_pvd = "force_chains.pvd";
// stems of the numbered .vtp snapshots under dem/vtk (<stem>_<k>.vtp)
inline constexpr std::string_view particles_stem = "particles";
inline constexpr std::string_view boundaries_stem = "boundaries";
inline constexpr std::string_view force_chains_stem = "force_chains";
// each solver's log
inline constexpr std::string_view log = "log.txt";
} // namespace file

// ---- columns ----------------------------------------------------------------------------------
namespace col {
inline constexpr Column time{"time", "s", "simulated time"};

// energy.csv (the DEM's energy budget, cumulative terms since the start)
inline constexpr Column kinetic{"kinetic", "J", "translational kinetic energy ½mv²"};
inline constexpr Column rotational{"rotational", "J", "rotational kinetic energy ½Iω²"};
inline constexpr Column potential{"potential", "J", "gravitational potential energy change"};
inline constexpr Column spring_normal{"spring_normal", "J", "energy in the normal springs"};
inline constexpr Column spring_shear{"spring_shear", "J", "energy in the shear springs"};
inline constexpr Column friction{"friction", "J", "dissipated by sliding friction"};
inline constexpr Column damping{"damping", "J", "dissipated by damping"};
inline constexpr Column rebound{"rebound", "J", "dissipated by the rebound rule"};
inline constexpr Column external_work{"external_work", "J", "work of the external loads"};
inline constexpr Column gravity_work{"gravity_work", "J", "work of gravity"};
inline constexpr Column imbalance{"imbalance", "J",
                                  "change of the total since the first step (0 before it)"};
inline constexpr Column left_scene{"left_scene", "J", "energy carried out of the scene"};

// structures.csv, per structure "<s>."
inline constexpr Column settlement{"settlement", "m", "−z displacement of the pivot"};
inline constexpr Column rotation{"rotation", "rad", "counter-clockwise rotation"};
inline constexpr Column moment{"moment", "N·m", "soil reaction moment about the pivot"};
inline constexpr Column force_x{"force_x", "N", "soil reaction, x"};
inline constexpr Column force_z{"force_z", "N", "soil reaction, z"};
inline constexpr Column applied_moment{"applied_moment", "N·m",
                                       "moment of the external loads about the pivot"};
inline constexpr Column displacement_x{"displacement_x", "m", "x displacement of the pivot"};
inline constexpr Column applied_force_x{"applied_force_x", "N", "the load history, x"};
inline constexpr Column applied_force_z{"applied_force_z", "N", "the load history, z"};

// walls.csv, per wall "<w>."
inline constexpr Column thrust{"thrust", "N", "soil force normal to the wall's chord, signed"};
inline constexpr Column reaction_x{"reaction_x", "N", "soil force on the wall, x"};
inline constexpr Column reaction_z{"reaction_z", "N", "soil force on the wall, z"};

// pressure_<t>.csv "<t>.bin<k>", surface.csv "surface.bin<k>": see bin_heading
inline constexpr Column pressure_bin{"bin", "Pa",
                                     "normal contact pressure on the target, height bin k"};
inline constexpr Column surface_bin{"bin", "m", "top of the highest particle in x bin k"};
inline constexpr std::string_view surface_owner = "surface";
// loci.csv "p<id>.x", "p<id>.z"
inline constexpr Column locus_x{"x", "m", "x of the traced particle"};
inline constexpr Column locus_z{"z", "m", "z of the traced particle"};
// coordination.csv
inline constexpr Column coordination{"coordination", "-",
                                     "2 × particle contacts / particles (the mean degree)"};

// the continuum's surface_profile.csv (not a time series: one row per x at the end of the run)
inline constexpr Column x{"x", "m", "position along the surface"};
inline constexpr Column surface_settlement{"settlement", "m", "downward displacement of the top"};

// the continuum's steps.csv (solver statistics per step)
inline constexpr Column step{"step", "", "step number"};
inline constexpr Column newton_iterations{"newton iterations", "", ""};
inline constexpr Column linear_iterations{"linear iterations", "", ""};
inline constexpr Column step_cuts{"step cuts", "", ""};
inline constexpr Column converged{"converged", "", "1 when the step converged"};
inline constexpr Column relative_residual{"relative residual", "", ""};
inline constexpr Column wall_seconds{"wall", "s", "wall-clock time of the step"};
inline constexpr Column explicit_substeps{"explicit substeps", "", ""};
} // namespace col

// The columns of each file, in order (after time; per owner where the file has owners).
inline constexpr std::array kEnergyColumns = {
    col::kinetic,       col::rotational,   col::potential, col::spring_normal,
    col::spring_shear,  col::friction,     col::damping,   col::rebound,
    col::external_work, col::gravity_work, col::imbalance, col::left_scene};
inline constexpr std::array kStructureColumns = {
    col::settlement, col::rotation,       col::moment,        col::force_x,
    col::force_z,    col::applied_moment, col::displacement_x};
// the continuum writes the load histories after each structure's columns
inline constexpr std::array kStructureLoadColumns = {col::applied_force_x, col::applied_force_z};
inline constexpr std::array kWallColumns = {col::thrust, col::reaction_x, col::reaction_z};
inline constexpr std::array kStepsColumns = {col::step,
                                             col::time,
                                             col::newton_iterations,
                                             col::linear_iterations,
                                             col::step_cuts,
                                             col::converged,
                                             col::relative_residual,
                                             col::wall_seconds,
                                             col::explicit_substeps};

// "<owner>.bin<k> [unit]" (pressure and surface profiles), and whether a column is one (with its
// owner and bin).
[[nodiscard]] std::string bin_heading(std::string_view owner, int k, const Column& c);
[[nodiscard]] bool is_bin_heading(std::string_view heading, std::string* owner = nullptr,
                                  int* k = nullptr);
// "p<id>" (loci.csv owners)
[[nodiscard]] std::string locus_owner(std::uint32_t id);

// ---- the listing ------------------------------------------------------------------------------
enum class Writer : std::uint8_t { Dem, Continuum, Both };
struct FileEntry {
  std::string_view name; // file name ("pressure_<target>.csv" for a pattern)
  Writer writer;         // under dem/, continuum/ or both
  std::string_view content;
};
// Every file a solver run writes under dem/ and continuum/, for the documentation and the tests.
[[nodiscard]] std::span<const FileEntry> run_directory();

} // namespace demfem::output
