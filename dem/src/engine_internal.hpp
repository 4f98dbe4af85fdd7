// Internal to the DEM engine's translation units (engine*.cpp): small helpers they share.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

#include "demfem/dem/engine.hpp"
#include "pair_kernel.hpp"

namespace demfem::dem::detail {

// The instruction set of the blocked kernels (pair loop, integration) for the configuration's
// switch: `simd` the widest the processor has, `avx2` at most AVX2, else the baseline.
inline Isa kernel_isa(EngineConfig::PairKernel k) {
  using PK = EngineConfig::PairKernel;
  return isa_up_to(k == PK::simd ? Isa::avx512 : k == PK::avx2 ? Isa::avx2 : Isa::portable);
}

// Active pairs (owner i < partner j) with their contact history and w extra history values each
// (px, w per pair; w = 0: none), stored as the CSR neighbour list (sorted by owner, then partner)
// that rebuild() merges with the new candidates.
inline void store_pairs_csr(std::size_t n, const std::vector<std::uint32_t>& pi,
                            const std::vector<std::uint32_t>& pj,
                            const std::vector<ContactHistory>& ph, const std::vector<double>& px,
                            std::size_t w, std::vector<std::uint32_t>& start,
                            std::vector<std::uint32_t>& partner, std::vector<ContactHistory>& hist,
                            std::vector<double>& extra) {
  std::vector<std::uint32_t> ord(pi.size());
  std::iota(ord.begin(), ord.end(), 0u);
  std::sort(ord.begin(), ord.end(), [&](std::uint32_t x, std::uint32_t y) {
    return pi[x] != pi[y] ? pi[x] < pi[y] : pj[x] < pj[y];
  });
  start.assign(n + 1, 0);
  partner.resize(ord.size());
  hist.resize(ord.size());
  extra.resize(ord.size() * w);
  for (std::size_t k = 0; k < ord.size(); ++k) {
    ++start[pi[ord[k]] + 1];
    partner[k] = pj[ord[k]];
    hist[k] = ph[ord[k]];
    for (std::size_t q = 0; q < w; ++q) extra[k * w + q] = px[ord[k] * w + q];
  }
  for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
}

// The two largest of a set of squared displacements (exact in any order, so the rebuild decision
// is the same for every thread count).
struct Top2 {
  double a = 0.0, b = 0.0; // a ≥ b
  void add(double v) {
    if (v > b) {
      if (v > a) {
        b = a;
        a = v;
      } else {
        b = v;
      }
    }
  }
  void merge(const Top2& o) {
    add(o.a);
    add(o.b);
  }
};

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr std::size_t kReorderFirstMin = 4096; // particles: reorder at the first rebuild

template <class T> void permute(std::vector<T>& v, const std::vector<std::uint32_t>& order) {
  std::vector<T> out(v.size());
  for (std::size_t k = 0; k < order.size(); ++k) out[k] = v[order[k]];
  v.swap(out);
}
// The same for w consecutive values per entry.
template <class T>
void permute(std::vector<T>& v, const std::vector<std::uint32_t>& order, std::size_t w) {
  std::vector<T> out(v.size());
  for (std::size_t k = 0; k < order.size(); ++k)
    for (std::size_t q = 0; q < w; ++q) out[k * w + q] = v[order[k] * w + q];
  v.swap(out);
}

// Interleaves the bits of x and z (Morton / Z-order key).
inline std::uint64_t morton(std::uint32_t x, std::uint32_t z) {
  auto spread = [](std::uint64_t v) {
    v &= 0xffffffffull;
    v = (v | (v << 16)) & 0x0000ffff0000ffffull;
    v = (v | (v << 8)) & 0x00ff00ff00ff00ffull;
    v = (v | (v << 4)) & 0x0f0f0f0f0f0f0f0full;
    v = (v | (v << 2)) & 0x3333333333333333ull;
    v = (v | (v << 1)) & 0x5555555555555555ull;
    return v;
  };
  return spread(x) | (spread(z) << 1);
}

} // namespace demfem::dem::detail
