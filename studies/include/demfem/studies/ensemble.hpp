// A seed ensemble of comparisons (issue 9): the same scene compared in several realisations of the
// DEM bed (scene.seed: the packing's radii and placement), each with the continuum calibrated from
// its own bed. One realisation cannot size a granular effect whose value depends on which disks
// carry a structure; the ensemble says, per metric, how far each solver's value spreads over the
// realisations and in how many of them the DEM's exceeds the continuum's.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace demfem::studies {

struct EnsembleMember {
  unsigned long long seed = 0;
  std::filesystem::path run_dir; // a `demfem compare` run directory (metrics.json, report.html)
};

struct EnsembleStat {
  double min = 0.0, median = 0.0, max = 0.0;
  int count = 0; // finite values
};

// One part (static value, late mean increment, oscillation amplitude) of one metric over the
// members: the values per member (NaN where a member lacks it), in member order.
struct EnsemblePart {
  std::vector<double> dem, continuum;
  EnsembleStat dem_stat, continuum_stat;
  EnsembleStat ratio; // |DEM| / |continuum| where both are finite and the continuum's is ≠ 0
  int dem_larger = 0; // members where |DEM| > |continuum| (by more than 0.1 %)
  int continuum_larger = 0; // members where |continuum| > |DEM| (by more than 0.1 %)
  int both = 0;             // members with both values finite
};

struct EnsembleRow {
  std::string key, quantity, unit;
  EnsemblePart static_part, increment, amplitude;
  std::string verdict; // plain words with the numbers (increment and amplitude)
  std::string figure;  // relative to the ensemble directory ("" when none)
};

struct Ensemble {
  std::vector<EnsembleMember> members; // those whose metrics.json could be read
  std::vector<std::string> missing;    // "seed N: why" for those that could not
  std::vector<EnsembleRow> rows;       // metrics in the first readable member's order
};

// Reads each member's metrics.json and summarises every metric row over the members.
[[nodiscard]] Ensemble summarise_ensemble(const std::vector<EnsembleMember>& members);

struct EnsembleFiles {
  std::filesystem::path json, html;
};

// Writes <dir>/ensemble.json, <dir>/ensemble.html (self-contained apart from its figures under
// <dir>/figures/, links to each member's report) for `ensemble`; `command` reproduces it. Figures
// need gnuplot (a missing one is skipped, as in the report). Throws scene::WriteError.
EnsembleFiles write_ensemble(const std::filesystem::path& dir, Ensemble& ensemble,
                             const std::string& title, const std::string& command);

} // namespace demfem::studies
