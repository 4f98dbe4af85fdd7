// The engine fingerprint (dem/pack.hpp): a digest of what this build's DEM does, bit for bit, on a
// small bed. It enters the packing and calibration cache keys, so a checkout never reuses a cache
// an engine that rounds differently wrote (the stale-cache failure of issue 12's twelfth session:
// a test passed on a machine with old caches and failed on a fresh clone).
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/scene/load.hpp"
#include "small_bed.hpp"

using namespace demfem;

TEST(EngineFingerprint, TheSameBuildGivesTheSameFingerprint) {
  const std::uint64_t a = dem::compute_engine_fingerprint();
  const std::uint64_t b = dem::compute_engine_fingerprint();
  EXPECT_EQ(a, b);
  EXPECT_EQ(dem::engine_fingerprint(), fmt::format("{:016x}", a));
  // The kernels are bit-identical by design (pair_kernel.hpp): the fingerprint follows the bits,
  // not the configuration.
  const std::uint64_t scalar = dem::compute_engine_fingerprint(
      [](dem::EngineConfig& c) { c.pair_kernel = dem::EngineConfig::PairKernel::scalar; });
  const std::uint64_t portable = dem::compute_engine_fingerprint(
      [](dem::EngineConfig& c) { c.pair_kernel = dem::EngineConfig::PairKernel::portable; });
  const std::uint64_t avx2 = dem::compute_engine_fingerprint(
      [](dem::EngineConfig& c) { c.pair_kernel = dem::EngineConfig::PairKernel::avx2; });
  EXPECT_EQ(scalar, a);
  EXPECT_EQ(portable, a);
  EXPECT_EQ(avx2, a);
}

TEST(EngineFingerprint, AnEngineThatRoundsDifferentlyGetsOtherCacheKeys) {
  // The change that made last session's caches stale: the Verlet skin (0.3 → 0.6 r_min) moves
  // the rebuilds, so the list order and the force sums' round-off.
  const std::uint64_t now = dem::compute_engine_fingerprint();
  const std::uint64_t old_skin =
      dem::compute_engine_fingerprint([](dem::EngineConfig& c) { c.skin_factor = 0.3; });
  EXPECT_NE(now, old_skin);
  const auto s =
      scene::parse_scene(test::small_bed("bed"), "bed.toml", demfem::app::vocabulary()).base;
  EXPECT_EQ(dem::packing_key(s), dem::packing_key(s, dem::engine_fingerprint()));
  EXPECT_NE(dem::packing_key(s, fmt::format("{:016x}", now)),
            dem::packing_key(s, fmt::format("{:016x}", old_skin)));
}
