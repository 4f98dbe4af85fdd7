// Replays the fuzzers' inputs in the default build (issue 13): every saved finding under
// fuzz/regressions/, every case file (the scene fuzzer's seed corpus), and a real run checkpoint
// with each of its truncations, through the same entry points the libFuzzer targets call. Each
// must be accepted or refused with the loader's own error, never crash or throw anything else.
#include <gtest/gtest.h>

#include "../scratch.hpp"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "demfem/app/vocabulary.hpp"
#include "targets.hpp"

namespace fs = std::filesystem;
using namespace demfem;

namespace {

std::vector<std::uint8_t> bytes_of(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<fs::path> files_in(const fs::path& dir) {
  std::vector<fs::path> v;
  if (fs::is_directory(dir))
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.is_regular_file() && e.path().filename() != "README.md") v.push_back(e.path());
  return v;
}

} // namespace

TEST(FuzzRegressions, SceneFindingsAndSeeds) {
  const fs::path src = DEMFEM_SOURCE_DIR;
  auto inputs = files_in(src / "fuzz/regressions/scene");
  for (const auto& f : files_in(src / "cases"))
    if (f.extension() == ".toml") inputs.push_back(f);
  ASSERT_GE(inputs.size(), 5u);
  for (const auto& f : inputs) {
    const auto b = bytes_of(f);
    EXPECT_NO_THROW(fuzz::scene_input(b)) << f;
  }
}

TEST(FuzzRegressions, CheckpointFindings) {
  for (const auto& f : files_in(fs::path(DEMFEM_SOURCE_DIR) / "fuzz/regressions/checkpoint")) {
    const auto b = bytes_of(f);
    EXPECT_NO_THROW(fuzz::checkpoint_input(b)) << f;
  }
}

// A run checkpoint of the settle-box engine ("DEMR" run header + engine state), whole and cut
// at every length: the whole one restores, every cut one is refused cleanly.
TEST(FuzzRegressions, RunCheckpointAndItsTruncations) {
  auto e = fuzz::settle_box_engine();
  const auto file = scene::load_scene_file(DEMFEM_SOURCE_DIR "/cases/verification/settle_box.toml",
                                           demfem::app::vocabulary());
  for (const auto& q : file.base.soil.dem->particles) e.add_particle(q[0], q[1], q[2]);
  e.set_dt(e.auto_dt());
  for (int k = 0; k < 20; ++k) e.step();
  dem::detail::ByteWriter w;
  w.value(std::uint32_t{0x44454d52u});
  w.value(std::uint32_t{1});
  w.bytes(e.save_state());
  dem::io::CheckpointMeta meta;
  meta.step = 20;
  meta.label = "settle-box";
  const fs::path p = demfem::test::scratch("run.ckpt");
  dem::io::write_checkpoint(p, e.particles(), meta, w.buffer());
  const auto whole = bytes_of(p);
  fs::remove(p);
  ASSERT_GT(whole.size(), 1000u);
  EXPECT_TRUE(fuzz::checkpoint_input(whole));
  int accepted = 0;
  for (std::size_t n = 0; n < whole.size(); n += 7) {
    const std::vector<std::uint8_t> cut(whole.begin(), whole.begin() + static_cast<long>(n));
    bool ok = false;
    EXPECT_NO_THROW(ok = fuzz::checkpoint_input(cut)) << n;
    accepted += ok;
  }
  EXPECT_EQ(accepted, 0) << "a truncated checkpoint was accepted";
}
