// Snapshot series: the paper shows its results as series of pictures at stated times
// (Ontake every 5–10 s, Fig. 3.5/3.6; retaining wall every 4 s, Figs. 6.5–6.8). From the run's
// .vtp output (dem/particles.pvd, force_chains.pvd, boundaries.pvd) and loci.csv, at the
// scene's output.series times (each from the nearest snapshot), three strips of panels:
//   series_force_chains.png  particles coloured by speed, normal-force chains (width ∝ |f_n|,
//                            one scale for the whole strip; tension dashed; at most the
//                            strongest max_chain_lines per panel)
//   series_velocity.png      particles coloured by speed; arrows: the mass-weighted mean
//                            velocity of the particles in each of ≈ 36 cells along the longer
//                            side (one scale for the whole strip)
//   series_loci.png          loci of the traced particles from the start up to each time
// The particles are drawn as images (figures/series/p<k>.png coloured, g<k>.png grey; 640
// pixels along the longer side), not as one gnuplot circle each.
// Report-side code, called by write_run_figures.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "demfem/compare/plot.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::compare {

struct SnapshotSeries {
  std::vector<double> requested;              // times asked for [s]
  std::vector<double> times;                  // times of the snapshots drawn [s]
  std::vector<std::filesystem::path> figures; // PNGs written
  std::vector<std::string> problems;          // what could not be drawn, and why
};

// The times of a scene's series: output.series within [0, duration], or six evenly spaced times
// from 0 to the duration when the scene gives none.
[[nodiscard]] std::vector<double> series_times(const scene::Scene& scene);

// Entries (time, file) of a ParaView .pvd collection; empty when missing or unreadable.
[[nodiscard]] std::vector<std::pair<double, std::filesystem::path>>
read_pvd(const std::filesystem::path& pvd);

// max_chain_lines: the chains drawn per panel, the strongest (|f_n|); the strip's title says so
// when a panel has more.
SnapshotSeries write_snapshot_series(const scene::Scene& scene,
                                     const std::filesystem::path& run_dir,
                                     std::size_t max_chain_lines = kChainLinesMax);

} // namespace demfem::compare
