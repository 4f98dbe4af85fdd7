// The two fuzzed entry points (issue 13), shared by the libFuzzer targets (fuzz_*.cpp, built with
// -DDEMFEM_FUZZ=ON by clang) and by the regression test that replays every saved finding and
// seed in the default build (tests/fuzz). Each returns normally for any input: a located scene
// error or a checkpoint error is the expected refusal; anything else (another exception, a
// crash, a sanitizer report, a runaway allocation) is a finding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unistd.h>

#include "../dem/src/state_bytes.hpp"
#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/scene/load.hpp"

namespace demfem::fuzz {

// A scene file's text: parsed, validated and resolved (every variant), then written back out.
// True when accepted.
inline bool scene_input(std::span<const std::uint8_t> data) {
  const std::string_view text(reinterpret_cast<const char*>(data.data()), data.size());
  try {
    const auto f = scene::parse_scene(text, "fuzz.toml", demfem::app::vocabulary());
    (void)scene::to_toml(f.base);
    for (const auto& v : f.variants) (void)scene::to_toml(v);
    return true;
  } catch (const scene::SceneError&) {
    return false; // refused with located diagnostics: expected
  }
}

// The engine a checkpoint's run state is restored into: the settle-box scene's walls and
// structures (as `demfem run` builds it before a resume).
inline dem::Engine settle_box_engine() {
  static const auto file = scene::load_scene_file(
      DEMFEM_SOURCE_DIR "/cases/verification/settle_box.toml", demfem::app::vocabulary());
  const auto& sc = file.base;
  dem::Engine e(dem::make_config(sc));
  for (const auto& w : sc.walls) e.add_wall(w);
  for (const auto& s : sc.structures) e.add_structure(s);
  return e;
}

// A checkpoint file's bytes: read (header, particle arrays, meta), then, when it carries a DEM
// run state ("DEMR" header), restored into an engine. True when read (and restored).
inline bool checkpoint_input(std::span<const std::uint8_t> data) {
  static const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                            ("demfem_fuzz_" + std::to_string(::getpid()) + ".ckpt");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data.data()),
              static_cast<std::streamsize>(data.size()));
  }
  std::optional<dem::io::Checkpoint> ck;
  try {
    ck = dem::io::read_checkpoint(path);
  } catch (const dem::io::IoError&) {
    std::filesystem::remove(path);
    return false; // refused with a message naming the file: expected
  }
  std::filesystem::remove(path); // read whole: leave nothing in the temporary directory
  try {
    dem::detail::ByteReader r(ck->extra);
    if (r.value<std::uint32_t>() != 0x44454d52u) return true; // not a run checkpoint ("DEMR")
    (void)r.value<std::uint32_t>();                           // run-state version
    auto e = settle_box_engine();
    e.restore_state(std::move(ck->particles), r.bytes());
    return true;
  } catch (const std::runtime_error&) {
    return false; // "engine state in checkpoint: …" and the engine's mismatch errors: expected
  }
}

} // namespace demfem::fuzz
