#include "demfem/compare/raster.hpp"

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstddef>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>
#include <png.h>

namespace demfem::compare::detail {

namespace {
// RGBA rows (row 0 at the bottom) as PNG bytes, through libpng: zlib level 1 and no row filter.
// VTK's writer (level 5, libpng's adaptive filters, which it does not let one change) took 45 % of
// a wall run's figure work in demfem for the strips' 14 layers (bench/RESULTS.md, twenty-fifth
// session); these layers are read once, by gnuplot.
std::string encode_png(const std::vector<unsigned char>& rgba, std::size_t w, std::size_t h) {
  std::string out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("particle layer: libpng could not start an image");
  }
  if (setjmp(png_jmpbuf(png))) { // libpng's errors return here
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("particle layer: libpng failed to encode the image");
  }
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t n) {
        static_cast<std::string*>(png_get_io_ptr(p))
            ->append(reinterpret_cast<const char*>(data), n);
      },
      nullptr);
  png_set_IHDR(png, info, static_cast<png_uint_32>(w), static_cast<png_uint_32>(h), 8,
               PNG_COLOR_TYPE_RGB_ALPHA, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, 1);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
  png_write_info(png, info);
  for (std::size_t r = h; r-- > 0;) // the top row first
    png_write_row(png, rgba.data() + 4 * w * r);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}
} // namespace

Raster raster_grid(double xmin, double xmax, double zmin, double zmax, double pixels) {
  Raster g;
  if (!(std::isfinite(xmin) && std::isfinite(xmax) && std::isfinite(zmin) && std::isfinite(zmax) &&
        xmax >= xmin && zmax >= zmin)) { // nothing to draw
    g.w = g.h = 0;
    return g;
  }
  g.px = std::max(xmax - xmin, zmax - zmin) / std::max(pixels, 1.0);
  if (!(g.px > 0.0)) g.px = 1.0;
  g.x0 = xmin;
  g.z0 = zmin;
  g.w = static_cast<int>(std::ceil((xmax - xmin) / g.px)) + 1;
  g.h = static_cast<int>(std::ceil((zmax - zmin) / g.px)) + 1;
  return g;
}

const char* const kPaletteGnuplot =
    "(0 '#2c7bb6', 0.25 '#abd9e9', 0.5 '#ffffbf', 0.75 '#fdae61', 1 '#d7191c')";

std::array<unsigned char, 3> palette_rgb(double t) {
  static constexpr double pos[5] = {0.0, 0.25, 0.5, 0.75, 1.0};
  static constexpr unsigned char rgb[5][3] = {{0x2c, 0x7b, 0xb6},
                                              {0xab, 0xd9, 0xe9},
                                              {0xff, 0xff, 0xbf},
                                              {0xfd, 0xae, 0x61},
                                              {0xd7, 0x19, 0x1c}};
  t = std::isfinite(t) ? std::clamp(t, 0.0, 1.0) : 0.0;
  std::size_t k = 0;
  while (k < 3 && t > pos[k + 1]) ++k;
  const double f = (t - pos[k]) / (pos[k + 1] - pos[k]);
  std::array<unsigned char, 3> c{};
  for (std::size_t q = 0; q < 3; ++q)
    c[q] = static_cast<unsigned char>(
        std::lround(rgb[k][q] + f * (static_cast<double>(rgb[k + 1][q]) - rgb[k][q])));
  return c;
}

std::string raster_png(const Raster& g, const std::vector<RasterDisk>& disks, double vmax,
                       const unsigned char* grey) {
  const auto w = static_cast<std::size_t>(std::max(g.w, 0));
  const auto h = static_cast<std::size_t>(std::max(g.h, 0));
  std::vector<unsigned char> pixels(4 * w * h, 0); // RGBA, row 0 at zmin
  unsigned char* px = pixels.data();
  const auto cell = [&](double v, double o, int n) {
    return static_cast<int>(std::clamp(std::floor((v - o) / g.px), 0.0, n - 1.0));
  };
  for (const auto& d : disks) {
    if (!std::isfinite(d.x) || !std::isfinite(d.z)) continue;
    std::array<unsigned char, 3> c{};
    if (grey)
      c = {grey[0], grey[1], grey[2]};
    else
      c = palette_rgb(vmax > 0.0 ? d.speed / vmax : 0.0);
    const auto put = [&](int i, int j) { // row 0 at zmin, written to the PNG last
      unsigned char* q = px + 4 * (static_cast<std::size_t>(j) * w + static_cast<std::size_t>(i));
      q[0] = c[0];
      q[1] = c[1];
      q[2] = c[2];
      q[3] = 255;
    };
    const int i0 = cell(d.x - d.r, g.x0, g.w), i1 = cell(d.x + d.r, g.x0, g.w);
    const int j0 = cell(d.z - d.r, g.z0, g.h), j1 = cell(d.z + d.r, g.z0, g.h);
    for (int j = j0; j <= j1; ++j) {
      const double zc = g.z0 + (j + 0.5) * g.px - d.z;
      for (int i = i0; i <= i1; ++i) {
        const double xc = g.x0 + (i + 0.5) * g.px - d.x;
        if (xc * xc + zc * zc <= d.r * d.r) put(i, j);
      }
    }
    put(cell(d.x, g.x0, g.w), cell(d.z, g.z0, g.h)); // a disk below a pixel still shows
  }
  return encode_png(pixels, w, h);
}

CellVelocity cell_mean_velocity(const std::vector<RasterDisk>& disks, double xmin, double xmax,
                                double zmin, double zmax, double cell) {
  CellVelocity v;
  if (!(cell > 0.0) || !(xmax >= xmin) || !(zmax >= zmin) || !std::isfinite(xmax - xmin) ||
      !std::isfinite(zmax - zmin))
    return v;
  v.cell = cell;
  v.ncx = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil((xmax - xmin) / cell)));
  v.ncz = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil((zmax - zmin) / cell)));
  const std::size_t nc = v.ncx * v.ncz;
  std::vector<double> w(nc, 0.0), sx(nc, 0.0), sz(nc, 0.0);
  for (const auto& q : disks) {
    if (!std::isfinite(q.x) || !std::isfinite(q.z)) continue;
    const auto ix =
        std::min(v.ncx - 1, static_cast<std::size_t>(std::max(0.0, (q.x - xmin) / cell)));
    const auto iz =
        std::min(v.ncz - 1, static_cast<std::size_t>(std::max(0.0, (q.z - zmin) / cell)));
    const double m = q.r * q.r; // mass ∝ r² (one density and thickness)
    w[iz * v.ncx + ix] += m;
    sx[iz * v.ncx + ix] += m * q.vx;
    sz[iz * v.ncx + ix] += m * q.vz;
  }
  v.vx.assign(nc, std::nan(""));
  v.vz.assign(nc, std::nan(""));
  for (std::size_t c = 0; c < nc; ++c)
    if (w[c] > 0.0) {
      v.vx[c] = sx[c] / w[c];
      v.vz[c] = sz[c] / w[c];
      v.vmax = std::max(v.vmax, std::hypot(v.vx[c], v.vz[c]));
    }
  return v;
}

std::string cell_arrows(const CellVelocity& v, double xmin, double zmin, double scale) {
  std::string out;
  for (std::size_t iz = 0; iz < v.ncz; ++iz)
    for (std::size_t ix = 0; ix < v.ncx; ++ix) {
      const std::size_t c = iz * v.ncx + ix;
      if (!std::isfinite(v.vx[c])) continue;
      const double ax = v.vx[c] * scale, az = v.vz[c] * scale; // centred on the cell's centre
      out += fmt::format("{:.7g} {:.7g} {:.7g} {:.7g}\n",
                         xmin + (static_cast<double>(ix) + 0.5) * v.cell - 0.5 * ax,
                         zmin + (static_cast<double>(iz) + 0.5) * v.cell - 0.5 * az, ax, az);
    }
  return out + "NaN NaN NaN NaN\n";
}

std::vector<std::size_t> strongest(const std::vector<double>& magnitude, std::size_t cap) {
  std::vector<std::size_t> idx(magnitude.size());
  for (std::size_t k = 0; k < idx.size(); ++k) idx[k] = k;
  if (idx.size() <= cap) return idx;
  const auto key = [&](std::size_t k) {
    return std::isnan(magnitude[k]) ? -std::numeric_limits<double>::infinity() : magnitude[k];
  };
  const auto first = [&](std::size_t a, std::size_t b) {
    const double ka = key(a), kb = key(b);
    return ka != kb ? ka > kb : a < b;
  };
  std::nth_element(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(cap), idx.end(), first);
  idx.resize(cap);
  std::sort(idx.begin(), idx.end());
  return idx;
}

// `plot 'file' binary filetype=png … with rgbalpha` drew the same pixels (0.1 % of a strip's
// pixels differ, at disk edges) but took ≈ 1 s more per 7-panel strip: gnuplot handles such an
// image pixel by pixel. A pixmap is scaled onto the rectangle by the terminal.
std::string raster_pixmap(const Raster& g, const std::string& file, int index) {
  return fmt::format("set pixmap {} '{}' at first {:.9g},{:.9g} size first {:.9g},{:.9g} back\n",
                     index, file, g.x0, g.z0, g.w * g.px, g.h * g.px);
}

} // namespace demfem::compare::detail
