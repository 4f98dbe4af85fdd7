// Figures and headline numbers of one DEM run, from what the run wrote under <run>/dem:
// structures.csv, walls.csv, surface.csv, loci.csv, energy.csv, vtk/particles_*.vtp and
// final.ckpt. Writes gnuplot PNG + SVG into <run>/figures and <run>/summary.json.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "demfem/scene/scene.hpp"

namespace demfem::compare {

struct RunFigures {
  std::vector<std::filesystem::path> figures; // PNGs written
  std::vector<std::string> problems;          // figures that could not be drawn, and why
  std::filesystem::path summary;              // summary.json
};

// `wall_seconds`, `steps`: the run's own totals (0 = unknown). Throws scene::WriteError when
// summary.json cannot be written. Never throws for a missing or
// malformed input file; it is listed in `problems`.
RunFigures write_run_figures(const scene::Scene& scene, const std::filesystem::path& run_dir,
                             double wall_seconds = 0.0, long long steps = 0);

// Area enclosed by the polyline (x_i, y_i) taken as a closed loop (shoelace), |Σ| / 2.
[[nodiscard]] double loop_area(const std::vector<double>& x, const std::vector<double>& y);

// Largest |v| over every particles_*.vtp snapshot under dir (0 when none can be read): `all` of
// every particle, `above` of those whose centre is at or above zmin (blocks falling out through an
// opened wall are not debris on the section).
struct PeakSpeeds {
  double all = 0.0, above = 0.0;
};
[[nodiscard]] PeakSpeeds peak_snapshot_speeds(const std::filesystem::path& vtk_dir,
                                              double zmin = -1e300);

} // namespace demfem::compare
