// FNV-1a 64-bit hash of the inputs of a cached result (packings, calibrations): the cache key.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "demfem/scene/scene.hpp"

namespace demfem::dem {

struct KeyHash {
  std::uint64_t h = 0xcbf29ce484222325ull; // FNV-1a 64 offset basis
  void bytes(const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= b[i];
      h *= 0x100000001b3ull; // FNV-1a 64 prime
    }
  }
  void num(double v) {
    if (v == 0.0) v = 0.0; // −0 and +0 hash alike
    bytes(&v, sizeof v);
  }
  void integer(long long v) { bytes(&v, sizeof v); }
  void str(const std::string& s) {
    integer(static_cast<long long>(s.size()));
    bytes(s.data(), s.size());
  }
  void points(const std::vector<scene::Vec2>& p) {
    integer(static_cast<long long>(p.size()));
    for (const auto& q : p) {
      num(q.x);
      num(q.z);
    }
  }
};

} // namespace demfem::dem
