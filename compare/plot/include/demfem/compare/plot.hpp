// Figures with gnuplot (PNG through pngcairo, and SVG): time series, profiles, loops and particle
// snapshots with force chains. Report-side code: never called from a physics kernel.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "demfem/dem/state.hpp"
#include "demfem/output/csv.hpp"

namespace demfem::compare {

// A CSV file of the run directory, read through its contract (output/csv.hpp).
using output::CsvTable;
using output::read_csv;

struct Series {
  std::string label;
  std::vector<double> x, y;
  std::string style = "lines"; // gnuplot style: lines, points, linespoints
  std::string extra;           // appended to the plot clause, e.g. "dt 2 lw 2"
};

struct PlotSpec {
  std::string title;
  std::string xlabel;
  std::string ylabel;
  std::vector<Series> series;
  bool equal_axes = false; // same scale on x and y (profiles, loci)
  int width = 1000;
  int height = 600;
  bool log_x = false; // logarithmic axes (convergence and error-vs-time figures)
  bool log_y = false;
};

// Figures whose scripts and data are written, to be drawn together by draw_queued: several
// scripts per gnuplot process (a small plot's time is mostly gnuplot's start).
struct PlotQueue {
  std::vector<std::filesystem::path> pngs, scripts;
};

// Writes `<stem>.png` and `<stem>.svg` (stem = path without extension) plus the gnuplot script and
// data beside them, so a person can re-plot. Returns false (and says why in `error`) when gnuplot
// is missing or fails, or when the figure came out cut short ("cannot write <file>: …", the cut
// files removed: a full disk). With a `queue` it only writes the
// script and data and queues the figure (false only for a figure with nothing to draw).
bool plot(const PlotSpec& spec, const std::filesystem::path& png, std::string* error = nullptr,
          PlotQueue* queue = nullptr);

// Force chains drawn per particle figure or strip panel: the strongest this many (|f_n|), the title
// saying so when there are more. A paper scene has a few thousand contacts, all drawn; 10⁶ disks
// have 1.7 million, each far below a pixel, which took 3 s of gnuplot and a 77 MB table per figure.
inline constexpr std::size_t kChainLinesMax = 20000;

struct SnapshotSpec {
  std::string title;
  bool force_chains = true;
  double chain_width_max = 4.0; // line width of the largest normal force
  bool velocity_arrows = false; // velocity field: the mean velocity of the particles in each of
                                // ≈ 48 cells along the longer side, the longest 0.9 cells long
                                // (drawn instead of force chains)
  std::size_t max_chain_lines = kChainLinesMax; // the strongest chains drawn
};

// Particles as disks coloured by speed, force chains as lines between centres with width ∝ |fn|
// (compression solid, tension dashed), boundaries as polylines. PNG only (with its gnuplot script
// and data, whose last line is the command for an SVG): a vector copy of thousands of disks is
// several times the PNG's size.
bool plot_particles(const dem::Particles& particles, const std::vector<dem::ContactView>& contacts,
                    const std::vector<dem::BoundaryView>& boundaries, const SnapshotSpec& spec,
                    const std::filesystem::path& png, std::string* error = nullptr,
                    PlotQueue* queue = nullptr);

// Draws the queued figures, their scripts split over at most `processes` gnuplot processes (0:
// one per core). One entry per queued figure, in order: empty when it was drawn, else the error
// (a process that fails has its scripts run again one by one, so the error names the figure).
std::vector<std::string> draw_queued(const PlotQueue& queue, unsigned processes = 0);

// Centred running mean over a window of `window` samples (the mean part of the wall force).
[[nodiscard]] std::vector<double> running_mean(const std::vector<double>& y, std::size_t window);

} // namespace demfem::compare
