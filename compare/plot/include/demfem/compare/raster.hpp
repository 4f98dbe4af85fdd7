// Internal to compare/: particles drawn as a PNG layer that gnuplot places behind a plot
// (`set pixmap … back`), for the snapshot strips (series.cpp) and the final snapshot figures
// (plot.cpp). Drawing thousands of disks `with circles` costs gnuplot one cairo fill each
// (≈ 0.35 s per strip panel of 3,400 disks); the layer is one image.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace demfem::compare::detail {

// A disk of radius r at (x, z) moving at (vx, vz): filled and coloured by speed in a layer, and
// counted in its cell's mean velocity.
struct RasterDisk {
  double x, z, r, vx, vz, speed;
};

// The pixel grid: pixel (0, 0)'s lower-left corner at (x0, z0), square pixels of px metres.
struct Raster {
  double x0 = 0.0, z0 = 0.0, px = 1.0;
  int w = 1, h = 1;
};
// `pixels` along the longer side of [xmin, xmax] × [zmin, zmax] (about the plot area it fills);
// w = h = 0 (nothing to draw) when the rectangle is empty or not finite (no particle left).
Raster raster_grid(double xmin, double xmax, double zmin, double zmax, double pixels);

// The palette of the strips and snapshots, for gnuplot's `set palette defined` and in RGB
// (linear between its points, as gnuplot interpolates it).
extern const char* const kPaletteGnuplot;
std::array<unsigned char, 3> palette_rgb(double t);

// PNG bytes (RGBA) of the disks: coloured by speed / vmax with the palette (the colour box's
// colours exactly), or all `grey`. Transparent between the disks.
std::string raster_png(const Raster& g, const std::vector<RasterDisk>& disks, double vmax,
                       const unsigned char* grey);

// The velocity field as arrows: the mass-weighted mean velocity (disks of one density: weights r²)
// of the particles whose centres lie in each square cell of `cell` metres, cells counted from
// (xmin, zmin); one arrow per particle (3,400 on the wall) drew a black mat, and 10⁶ of them took
// 6 s of gnuplot. vx, vz: per cell, row by row from zmin, NaN where no centre lies; vmax: the
// largest |mean|.
struct CellVelocity {
  double cell = 1.0;
  std::size_t ncx = 0, ncz = 0;
  std::vector<double> vx, vz;
  double vmax = 0.0;
};
CellVelocity cell_mean_velocity(const std::vector<RasterDisk>& disks, double xmin, double xmax,
                                double zmin, double zmax, double cell);
// Its arrows for gnuplot's `with vectors`: "x z dx dz" per non-empty cell, centred on the cell's
// centre, `scale` metres per (m/s), then a "NaN" line (an empty field still plots).
std::string cell_arrows(const CellVelocity& v, double xmin, double zmin, double scale);

// The indices of the `cap` largest of `magnitude` (ties: the lower index; NaN the smallest), in
// increasing index order; every index when there are at most `cap`. The force chains drawn
// (SnapshotSpec::max_chain_lines).
std::vector<std::size_t> strongest(const std::vector<double>& magnitude, std::size_t cap);

// The gnuplot command that places the PNG `file` over the grid's rectangle, as pixmap `index`.
std::string raster_pixmap(const Raster& g, const std::string& file, int index);

} // namespace demfem::compare::detail
