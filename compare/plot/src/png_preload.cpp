// demfem_png_preload: a module that demfem's figure runner (plot.cpp, gnuplot_environment) loads
// into the gnuplot processes it starts (LD_PRELOAD), so that gnuplot's pngcairo terminal encodes
// its PNGs with zlib level 3 and no row filter instead of libpng's defaults (level 6, adaptive
// filters). The pixels are the same; encoding was ≈ 40 % of a snapshot strip's gnuplot time
// (bench/RESULTS.md, twenty-fifth session). It wraps png_write_info, which only writers call,
// once per image before any image data; everything else in gnuplot is untouched. It links no
// libpng of its own: the functions are those of the libpng the process already loaded, found
// with dlsym, and when one is missing the image is written with the defaults.
#include <dlfcn.h>

namespace {
using WriteInfo = void (*)(void*, void*);
using SetLevel = void (*)(void*, int);
using SetFilter = void (*)(void*, int, int);
constexpr int kLevel = 3; // zlib level (libpng's default 6: bench/RESULTS.md, twenty-fifth session)
constexpr int kFilterNone = 0x08;  // PNG_FILTER_NONE (png.h)
constexpr int kFilterTypeBase = 0; // PNG_FILTER_TYPE_BASE
template <class F> F next(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}
} // namespace

extern "C" [[gnu::visibility("default")]] void png_write_info(void* png, void* info) {
  static const auto real = next<WriteInfo>("png_write_info");
  static const auto level = next<SetLevel>("png_set_compression_level");
  static const auto filter = next<SetFilter>("png_set_filter");
  if (png) {
    if (level) level(png, kLevel);
    if (filter) filter(png, kFilterTypeBase, kFilterNone);
  }
  if (real) real(png, info);
}
