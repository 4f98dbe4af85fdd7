// Issue 13: a run never reports success over missing or stale results. Stop signals checkpoint
// and resume bit for bit; a used run directory of another scene is refused unless --force; a
// failed write ends the run with exit 1 naming the file.
#include <chrono>
#include <csignal>
#include <filesystem>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "cli_util.hpp"

namespace fs = std::filesystem;
using namespace demfem::test;

namespace {

const fs::path kSource = DEMFEM_SOURCE_DIR;

fs::path scratch(const std::string& name) {
  const fs::path p =
      fs::temp_directory_path() / ("demfem_safety_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p;
}

// The settle-box scene (120 disks, a footing, probes and VTK snapshots) for `duration` seconds,
// without figures (they are not what these tests are about, and gnuplot is slow).
fs::path settle_box(const std::string& name, double duration) {
  auto text = with_values(slurp(kSource / "cases/verification/settle_box.toml"),
                          {{"duration", std::to_string(duration)}});
  const auto pos = text.find("\n[output]\n");
  if (pos != std::string::npos) text.insert(pos + 10, "figures = false\n");
  return write_temp("demfem_safety_" + name + "_" + std::to_string(::getpid()) + ".toml", text);
}

} // namespace

// SIGTERM (a batch scheduler's stop) and SIGHUP (a closed terminal) behave like Ctrl-C: the run
// finishes its step, writes a checkpoint, prints the resume command and exits 3; `--resume` then
// ends with every file under dem/ byte-identical to an uninterrupted run's.
TEST(RunSignals, StopSignalsCheckpointAndResumeByteIdentical) {
  const auto scene = settle_box("signals", 8.0);
  const fs::path ref = scratch("signals_ref");
  const auto r0 = run("run " + scene.string() + " --out " + ref.string());
  ASSERT_EQ(r0.code, 0) << r0.out;
  const auto expected = files_under(ref / "dem");
  ASSERT_TRUE(expected.count("final.ckpt"));
  ASSERT_TRUE(expected.count("structures.csv"));

  for (const int sig : {SIGTERM, SIGHUP}) {
    SCOPED_TRACE(sig == SIGTERM ? "SIGTERM" : "SIGHUP");
    const fs::path out = scratch("signals_split");
    {
      Child c({"run", scene.string(), "--out", out.string()}, out.string() + ".log");
      ASSERT_TRUE(c.started());
      // Signal once the time loop is running: energy.csv has had its first rows flushed.
      const auto energy = out / "dem" / "energy.csv";
      while (c.running()) {
        std::error_code ec;
        if (fs::file_size(energy, ec) > 2000 && !ec) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
      c.signal(sig);
      const auto r = c.wait();
      ASSERT_EQ(r.code, 3) << r.out;
      EXPECT_NE(r.out.find("interrupted at t ="), std::string::npos) << r.out;
      EXPECT_NE(r.out.find(sig == SIGTERM ? "stopped by SIGTERM" : "stopped by SIGHUP"),
                std::string::npos)
          << r.out;
      EXPECT_NE(r.out.find("--out " + out.string() + " --resume"), std::string::npos) << r.out;
      EXPECT_TRUE(fs::exists(out / "dem" / "checkpoint.ckpt"));
      EXPECT_FALSE(fs::exists(out / "dem" / "final.ckpt"));
      EXPECT_FALSE(fs::exists(out / "dem" / "checkpoint.ckpt.tmp"));
      fs::remove(out.string() + ".log");
    }
    const auto r2 = run("run " + scene.string() + " --out " + out.string() + " --resume");
    ASSERT_EQ(r2.code, 0) << r2.out;
    const auto got = files_under(out / "dem");
    EXPECT_EQ(got.size(), expected.size());
    for (const auto& [name, bytes] : expected) {
      const auto it = got.find(name);
      ASSERT_NE(it, got.end()) << name << " missing after the resume";
      EXPECT_TRUE(it->second == bytes) << name << " differs from the uninterrupted run";
    }
    fs::remove_all(out);
  }
  fs::remove_all(ref);
  fs::remove(scene);
}
