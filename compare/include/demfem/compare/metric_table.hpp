// The metric table: every metric the comparison reports is one row. A row says what it compares
// (a time series or a profile), whose it is (each wall, each structure, each pressure probe, or
// the scene's), where both solvers' outputs hold it (file and column names of the run-directory
// contract, output/contract.hpp), how it is reduced to numbers, its unit and the scale its
// figures use, the threshold of its verdict, and whether it is a verdict (the two methods may
// differ), a check (an identity both must satisfy) or only shown.
//
// collect_metrics (metrics.hpp) reads the series rows, compare_profiles (profiles.hpp) the
// profile rows, and write_report (report.hpp) reports both; adding a metric that reads and
// reduces as an existing row does is adding a row.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <string_view>

#include "demfem/output/contract.hpp"

namespace demfem::compare {

// What a row compares.
enum class Subject : std::uint8_t {
  Series,  // one quantity against time
  Profile, // one quantity along a line (the bins of a probe) at stated times
};

// Whose quantity it is: one metric per owner (its key "<owner>.<key>"), or one for the scene.
enum class Owners : std::uint8_t {
  Walls,           // each wall: an owner with a thrust column (walls.csv)
  Structures,      // each structure, walls included (structures.csv)
  Bodies,          // each structure that is not a wall
  PressureTargets, // each target of a pressure-profile probe (pressure_<target>.csv)
  Scene,           // one metric; its key is the row's key
};

// How both solvers' outputs yield it.
enum class Read : std::uint8_t {
  Column,       // the column "<owner>.<column>" ("<column>" for the scene) of `file`, a time
                // series both solvers write under dem/ and continuum/
  SurfaceMean,  // DEM: `file` (surface.csv), the mean over its x bins; continuum: the top of the
                // soil cells of each .vtu snapshot plus its vertical displacement, binned alike
                // and averaged
  PressureBins, // the "<target>.bin<k>" columns of pressure_<target>.csv in both solvers
  SurfaceBins,  // DEM: the particles that formed the surface at rest followed to the end
                // (particles.pvd), else the top of the bed per bin (`file`, surface.csv);
                // continuum: the top of the soil cells per bin from the .vtu snapshots
};

struct Source {
  Read read = Read::Column;
  std::string_view file{}; // output::file name; "" where the reader names its own files
  output::Column column{}; // the column read (Read::Column) or the bins' column (profiles)
};

// How the values are reduced to the numbers a verdict or a figure uses. Every reduction uses the
// split options (metrics.hpp SplitOptions: the load start, the moving-average window, the late
// window), so a window rule changes in one place.
enum class Reduction : std::uint8_t {
  Split,           // static value at rest, mean increment over the late window, oscillation
                   // amplitude over it (split_series); divergence measured on the increments
  RestAndLateMean, // per bin: the mean at rest and the mean over the late window
  EndMinusRest,    // per bin: the value at rest minus the value at the end (down positive), with
                   // the largest both ways and where
};

// What the report makes of it.
enum class Role : std::uint8_t {
  Verdict, // the two methods may differ: "agree" or "diverge" against the threshold
  Check,   // an identity both solvers must satisfy (equilibrium, momentum of a closed box):
           // "holds" or "fails", judged on the same numbers as a verdict
  Shown,   // drawn and recorded, judged by neither (the profiles)
};

// The structure degree of freedom a metric measures: where the scene fixes it, the metric is 0 in
// both solvers and is listed as such, not compared.
enum class Dof : std::uint8_t { None, X, Z, Rotation };

// How a figure shows the values: figure value = factor × SI value, in `unit` ("": the row's).
// factor 0: chosen from the values (a displacement profile: mm below 1 cm, else cm).
struct Scale {
  double factor = 1.0;
  std::string_view unit{};
};

// Metric::rank below this: the key quantities.
inline constexpr int kKeyRanks = 4;

struct Metric {
  std::string_view key{}; // "thrust": the metric "<owner>.thrust"; the whole key for the scene
  // plain words, after the owner's name: unique among the rows one owner gets
  std::string_view quantity{};
  Subject subject = Subject::Series;
  Owners owners = Owners::Scene;
  Source source{};
  Reduction reduction = Reduction::Split;
  std::string_view unit{}; // SI unit of the values
  Scale scale{};
  // relative threshold of the verdict or check; NaN: the report's (divergence_threshold)
  double threshold = std::numeric_limits<double>::quiet_NaN();
  Role role = Role::Verdict;
  // order in the report (stable within a rank): below kKeyRanks the key quantities (thrust,
  // settlement, rotation, surface), which `demfem study error-vs-time` also measures
  int rank = 10;
  Dof dof = Dof::None;
  // metrics.json member holding a profile's values (per owner: an object keyed by owner); ""
  // for a series, recorded in "metric_table" and "rows"
  std::string_view record{};
  std::string_view meaning{}; // one line: what it is physically
};

// A column the solvers write that is a metric's quantity under another name, listed once in the
// report instead of being compared twice (or the load's own history: same_as empty). Listed for
// an owner whose files have the column, when the table compares its same_as.
struct OtherName {
  Owners owners;
  output::Column column;
  output::Column same_as; // the metric's column; empty name: the applied load (an input)
  std::string_view why;
};

// The built-in table, in report order within each rank, and the other names.
[[nodiscard]] std::span<const Metric> metric_table();
[[nodiscard]] std::span<const OtherName> other_names();

// A row's fields agree with each other: a series is read from a column or the surface and split;
// a profile is shown, not judged; only a displacement profile chooses its scale from its values;
// pressure bins are read per pressure target and reduced to their rest and late means, the
// surface's bins once for the scene and reduced to end − rest; a column is read from a named file.
// (A profile read or reduced another way is a new reader in profiles.cpp, then rows.)
[[nodiscard]] constexpr bool consistent(const Metric& m) {
  const Read r = m.source.read;
  const bool series = m.subject == Subject::Series;
  const bool series_read = r == Read::Column || r == Read::SurfaceMean;
  const bool split = m.reduction == Reduction::Split;
  const bool surface = r == Read::SurfaceMean || r == Read::SurfaceBins;
  return !m.key.empty() && !m.quantity.empty() && series == m.record.empty() &&
         series == series_read && series == split && (series || m.role == Role::Shown) &&
         (r == Read::PressureBins) == (m.owners == Owners::PressureTargets) &&
         (r == Read::PressureBins) == (m.reduction == Reduction::RestAndLateMean) &&
         (r == Read::SurfaceBins) == (m.reduction == Reduction::EndMinusRest) &&
         (!surface || m.owners == Owners::Scene) && (r != Read::Column || !m.source.file.empty()) &&
         (m.scale.factor > 0.0 || m.reduction == Reduction::EndMinusRest);
}

} // namespace demfem::compare
