// The comparison's series: each metric of the table (metric_table.hpp) that is a time series, read
// for every owner from a run directory's dem/ and continuum/ outputs. Every compared series is
// split into its static value (the state at rest before the loading starts), its increment
// (series − static) and its oscillation (increment − its moving average over whole loading
// periods); divergence is measured on the increments, so an at-rest offset between the two models
// does not hide or fake a divergence.
#pragma once

#include <filesystem>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "demfem/compare/metric_table.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::compare {

// One row of the metric table applied to one owner.
struct MetricDef {
  std::string key;              // "wall.thrust": unique over the table
  std::string owner;            // "wall"; "" for the scene's
  std::string quantity;         // "wall thrust": plain words, unique over the table
  std::string unit;             // "N"
  std::string dem_source;       // how the DEM output yields it
  std::string continuum_source; // how the continuum output yields it
  std::string meaning;          // one line: what it is physically
  Role role = Role::Verdict;
  double threshold = std::numeric_limits<double>::quiet_NaN(); // NaN: the caller's
  int rank = 10;                                               // Metric::rank
  Scale scale{};                                               // Metric::scale
};

struct TimeSeries {
  std::vector<double> t, y;
};

struct MetricSeries {
  MetricDef def;
  TimeSeries dem, continuum;
  std::string note; // e.g. "0 in both: the scene fixes the structure's vertical motion"
};

// Columns of the solvers' CSVs that are the same physical quantity as a canonical one, and why
// they are not compared separately (listed in the report so nothing silently disappears).
struct Alias {
  std::string column;  // "wall.reaction_x [N]"
  std::string same_as; // canonical key
  std::string why;
};

struct MetricSet {
  std::vector<MetricSeries> series;  // compared quantities, key ones first
  std::vector<Alias> aliases;        // columns folded into a canonical quantity
  std::vector<MetricSeries> zero;    // identically zero in both solvers (fixed by the scene)
  std::vector<std::string> warnings; // e.g. a structure the DEM's particles never touch
  // Share of the soil's area where the continuum's last snapshot is beyond small strains
  // (continuum_strain_range, kSmallStrainLimit); 0: within them, or no snapshot.
  double continuum_beyond_small_strain = 0.0;
};

// Reads <run>/dem/*.csv and <run>/continuum/*.csv (+ the continuum's .vtu snapshots for the
// surface) and builds one series pair per series row of `table` and owner. `scene` may be null
// (then the structure kinds and the domain come from the files alone).
[[nodiscard]] MetricSet collect_metrics(const std::filesystem::path& run_dir,
                                        const scene::Scene* scene,
                                        std::span<const Metric> table = metric_table());
// The same table for one solver's run alone (the other side of every series stays empty): a
// quantity is listed when that solver wrote it and it is not 0 throughout; the continuum's surface
// is binned as the scene's surface-profile probe. Used by `demfem study error-vs-time` to measure
// a run against the most resolved run of the same solver with the comparison's own metrics.
[[nodiscard]] MetricSet collect_solver_metrics(const std::filesystem::path& run_dir,
                                               const scene::Scene* scene, scene::Solver solver,
                                               std::span<const Metric> table = metric_table());

// ---- the static / increment / oscillation split -------------------------------------------------
struct SplitOptions {
  double load_start = 0.0; // the loading (shaking, structure load) starts here [s]
  double window = 1.0;     // moving-average window: whole loading periods [s]
  double late_from = 0.0;  // the "late" window over which the mean increment and the
  double late_to = 0.0;    // oscillation amplitude are taken [s]
  double period = 0.0;     // loading period [s] (0: unknown): amplitude needs ≥ 4 samples/period
};

struct Split {
  double static_value = 0.0;   // mean at rest: over [load_start/2, load_start], or the first
                               // sample when the load starts at t ≈ 0
  double mean_increment = 0.0; // mean of (y − static) over the late window
  double amplitude = 0.0;      // √2 · RMS of the oscillation over the late window (the amplitude
                               // of a sine with that RMS); NaN when sampled too coarsely
  std::vector<double> increment; // y − static, per sample
  std::vector<double> mean;      // moving average of the increment over `window`, per sample
};

[[nodiscard]] Split split_series(const TimeSeries& s, const SplitOptions& o);

// Centred moving average of y(t) over a time window (samples inside [t − w/2, t + w/2]).
[[nodiscard]] std::vector<double> moving_average(const std::vector<double>& t,
                                                 const std::vector<double>& y, double window);

// The split options the scene implies: load start and period from [load.shaking] or from the
// structures' force/moment histories; the late window is the last third of the loading span.
[[nodiscard]] SplitOptions split_options(const scene::Scene* scene, double t_end);

struct Part {
  double dem = 0.0, continuum = 0.0;
  [[nodiscard]] double difference() const { return continuum - dem; }
  [[nodiscard]] double relative() const; // (continuum − dem)/|dem|; NaN when dem is 0 or NaN
};

struct MetricRow {
  MetricDef def;
  Part static_part, increment, amplitude;
  double first_divergence = -1.0; // first t ≥ load start where |Δ increment| > thr·max|inc_dem|
  double first_divergence_mean = -1.0; // the same on the moving averages of the increments
  bool diverges = false;
  bool comparable = true; // false when one solver's series is 0 throughout (nothing measured)
  std::string verdict;    // plain words with the numbers
  Split dem_split, continuum_split;
  // The largest |mean increment| or amplitude of the two solvers (finite ones; 0 when none).
  [[nodiscard]] double largest_response() const;
};

// Compares one series pair: both split with `o`, divergence on the increments with the row's
// threshold, or `threshold` where the row gives none (relative to the DEM's largest |increment|);
// the verdict compares the late mean increments and the oscillation amplitudes with the same
// relative threshold. When every mean increment and
// amplitude of a force, moment or pressure (not a unit of m or rad) is below kSmallResponseShare
// of the DEM's static value, the verdict says so (the agree/diverge word does not change).
inline constexpr double kSmallResponseShare = 0.01;
[[nodiscard]] MetricRow compare_metric(const MetricSeries& m, const SplitOptions& o,
                                       double threshold);

// The word of a compared row: "agree" / "diverge" (a verdict), "holds" / "fails" (a check), "n/a"
// (not comparable).
[[nodiscard]] std::string_view outcome_word(const MetricRow& r);

} // namespace demfem::compare
