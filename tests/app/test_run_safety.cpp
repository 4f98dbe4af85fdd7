// A run never reports success over missing or stale results. Stop signals checkpoint
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

// The settle-box scene (120 disks, a footing, probes and VTK snapshots) for `duration` seconds,
// without figures (they are not what these tests are about, and gnuplot is slow).
fs::path settle_box(const std::string& name, double duration) {
  auto text = with_values(slurp(kSource / "cases/verification/settle_box.toml"),
                          {{"duration", std::to_string(duration)}});
  const auto pos = text.find("\n[output]\n");
  if (pos != std::string::npos) text.insert(pos + 10, "figures = false\n");
  return write_temp("safety_" + name + ".toml", text);
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

// A second scene run into a used directory is refused (exit 2, nothing touched); with --force the
// old results are cleared first, so its summary holds only its own quantities. The same scene
// again overwrites.
TEST(RunDirectory, AnotherSceneIsRefusedUnlessForced) {
  const auto a = settle_box("dir_a", 0.3);
  auto a_text = slurp(a);
  a_text.replace(a_text.find("figures = false\n"), 16, "");
  std::ofstream(a) << a_text; // with figures and summary.json
  const auto b = write_temp(
      "safety_dir_b.toml", with_values(slurp(kSource / "cases/verification/rebounding_settle.toml"),
                                       {{"duration", "0.3"}}));
  const fs::path out = scratch("dir");
  const auto ra = run("run " + a.string() + " --out " + out.string());
  ASSERT_EQ(ra.code, 0) << ra.out;
  ASSERT_TRUE(fs::exists(out / "dem" / "structures.csv"));

  // The same scene again: overwritten, exit 0.
  const auto again = run("run " + a.string() + " --out " + out.string());
  EXPECT_EQ(again.code, 0) << again.out;
  const auto summary_a = slurp(out / "summary.json");
  ASSERT_NE(summary_a.find("\"footing\""), std::string::npos) << summary_a;

  const auto refused = run("run " + b.string() + " --out " + out.string());
  EXPECT_EQ(refused.code, 2) << refused.out;
  EXPECT_NE(refused.out.find("holds the results of a different scene"), std::string::npos)
      << refused.out;
  EXPECT_NE(refused.out.find("--force"), std::string::npos) << refused.out;
  EXPECT_EQ(slurp(out / "summary.json"), summary_a) << "a refused run touched the directory";
  EXPECT_NE(slurp(out / "scene.resolved.toml").find("settle-box"), std::string::npos);

  const auto forced = run("run " + b.string() + " --out " + out.string() + " --force");
  ASSERT_EQ(forced.code, 0) << forced.out;
  const auto summary_b = slurp(out / "summary.json");
  EXPECT_NE(summary_b.find("\"rebounding-settle\""), std::string::npos) << summary_b;
  for (const char* stale : {"footing", "settle-box", "base.thrust", "\"surface\""})
    EXPECT_EQ(summary_b.find(stale), std::string::npos) << stale << " in\n" << summary_b;
  for (const char* stale : {"structures.csv", "walls.csv", "surface.csv", "coordination.csv"})
    EXPECT_FALSE(fs::exists(out / "dem" / stale)) << stale;
  // Every snapshot is the new run's: 0.3 s at interval 0.25 → 0, 0.25 and the end.
  int snapshots = 0;
  for (const auto& e : fs::directory_iterator(out / "dem" / "vtk"))
    snapshots += e.path().filename().string().rfind("particles_", 0) == 0;
  EXPECT_EQ(snapshots, 3);
  fs::remove_all(out);
  fs::remove(a);
  fs::remove(b);
}

namespace {

// A figure is complete when a PNG ends with its IEND chunk and an SVG with </svg>.
bool complete_image(const fs::path& f) {
  const auto b = slurp(f);
  if (f.extension() == ".png")
    return b.size() >= 12 &&
           b.compare(b.size() - 12, 12, std::string("\0\0\0\0IEND\xae\x42\x60\x82", 12)) == 0;
  return b.find("</svg>") != std::string::npos;
}

// What an exit-0 run lists, all present and whole: the final checkpoint, summary.json, every
// figure, every snapshot named in a .pvd collection, every CSV ending in a full row, and no
// temporary file left over.
void expect_complete_run(const fs::path& out, const std::string& context) {
  EXPECT_GT(fs::exists(out / "dem" / "final.ckpt") ? fs::file_size(out / "dem" / "final.ckpt") : 0,
            0u)
      << context;
  const auto summary = slurp(out / "summary.json");
  EXPECT_TRUE(summary.size() > 2 && summary.substr(summary.size() - 2) == "}\n") << context;
  int figures = 0;
  for (const auto& [name, bytes] : files_under(out)) {
    const fs::path p = out / name;
    EXPECT_NE(p.extension(), ".tmp") << context << ": left " << name;
    if (p.extension() == ".png" || p.extension() == ".svg") {
      figures += p.extension() == ".png";
      EXPECT_TRUE(complete_image(p)) << context << ": " << name << " is cut short";
    }
    if (p.extension() == ".csv") {
      EXPECT_TRUE(!bytes.empty() && bytes.back() == '\n') << name;
    }
    if (p.extension() == ".pvd") {
      EXPECT_NE(bytes.find("</VTKFile>"), std::string::npos) << context << ": " << name;
      for (auto pos = bytes.find("file=\""); pos != std::string::npos;
           pos = bytes.find("file=\"", pos + 6)) {
        const auto end = bytes.find('"', pos + 6);
        const auto vtp = p.parent_path() / bytes.substr(pos + 6, end - pos - 6);
        EXPECT_TRUE(fs::exists(vtp) && fs::file_size(vtp) > 0) << context << ": " << vtp;
      }
    }
  }
  EXPECT_GT(figures, 0) << context;
}

} // namespace

// A run whose files may not grow past a size limit (RLIMIT_FSIZE in the child, SIGXFSZ ignored:
// every write beyond it fails with EFBIG, as on a full disk) either fails with exit 1, naming
// the file it could not write (on stderr and, when log.txt itself still fits, in log.txt), or
// exits 0 with every output it lists present and whole.
TEST(CheckedWrites, FileSizeLimitFailsNamingTheFileOrLeavesCompleteOutputs) {
  const auto scene = settle_box("fsize", 0.3);
  auto text = slurp(scene);
  text.replace(text.find("figures = false\n"), 16, "");
  std::ofstream(scene) << text;
  int failed = 0, passed = 0;
  for (const long long limit : {2000LL, 8000LL, 20000LL, 60000LL, 200000LL, 100000000LL}) {
    const std::string context = "limit " + std::to_string(limit) + " bytes";
    const fs::path out = scratch("fsize_" + std::to_string(limit));
    const fs::path log = out.string() + ".log";
    Child c({"run", scene.string(), "--out", out.string()}, log, limit);
    const auto r = c.wait();
    ASSERT_TRUE(r.code == 0 || r.code == 1) << context << ": exit " << r.code << "\n" << r.out;
    if (r.code == 1) {
      ++failed;
      // "cannot write <file>: File too large (…)" or a solver/VTK error naming the file
      EXPECT_NE(r.out.find(out.string() + "/"), std::string::npos) << context << "\n" << r.out;
      EXPECT_TRUE(r.out.find("File too large") != std::string::npos ||
                  r.out.find("cannot write") != std::string::npos ||
                  r.out.find("cut short") != std::string::npos ||
                  r.out.find("gnuplot failed") != std::string::npos)
          << context << "\n"
          << r.out;
      EXPECT_EQ(r.out.find("filesystem error"), std::string::npos) << r.out;
      const auto run_log = slurp(out / "log.txt");
      if (!run_log.empty() && static_cast<long long>(run_log.size()) + 1000 < limit) {
        EXPECT_NE(run_log.find("run failed"), std::string::npos) << context << "\n" << run_log;
      }
    } else {
      ++passed;
      expect_complete_run(out, context);
    }
    fs::remove_all(out);
    fs::remove(log);
  }
  EXPECT_GE(failed, 1);
  EXPECT_GE(passed, 1); // the largest limit is far above what the run writes
  fs::remove(scene);
}

// An --out that cannot be created is a clear message (exit 1), not a raw filesystem error.
TEST(CheckedWrites, UnwritableOutIsAClearMessage) {
  const auto scene = settle_box("unwritable", 0.05);
  const auto file = write_temp("safety_not_a_dir", "x");
  const auto r = run("run " + scene.string() + " --out " + (file / "run").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("cannot create the run directory " + (file / "run").string()),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("Not a directory"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("filesystem error"), std::string::npos) << r.out;
  fs::remove(file);
  fs::remove(scene);
}

#ifdef DEMFEM_TEST_CONTINUUM
// The continuum's outputs (.vtu pieces, .pvtu and .pvd records, the CSV series, the surface
// profile) go through checked writes too: under a file size limit a run either exits 1 naming
// the file and the cause, or exits 0 with every output complete; never a silent partial output.
TEST(CheckedWrites, ContinuumFileSizeLimitFailsNamingTheFileOrLeavesCompleteOutputs) {
  const auto scene = write_temp(
      "footing.toml", with_values(slurp(kSource / "cases/verification/continuum_footing_load.toml"),
                                  {{"duration", "0.06"}, {"interval", "0.02"}}));
  // Open MPI's PMIx keeps its shared-memory store in files far above these limits, so that
  // MPI_Init itself would fail: the hash store keeps it in memory.
  ::setenv("PMIX_MCA_gds", "hash", 1);
  int failed = 0, passed = 0;
  for (const long long limit : {600LL, 3000LL, 20000LL, 100000000LL}) {
    const std::string context = "limit " + std::to_string(limit) + " bytes";
    const fs::path out = scratch("continuum_fsize_" + std::to_string(limit));
    const fs::path log = out.string() + ".log";
    Child c({"run", scene.string(), "--solver", "continuum", "--out", out.string()}, log, limit);
    const auto r = c.wait();
    ASSERT_TRUE(r.code == 0 || r.code == 1) << context << ": exit " << r.code << "\n" << r.out;
    for (const auto& [name, bytes] : files_under(out))
      EXPECT_NE(fs::path(name).extension(), ".tmp") << context << ": left " << name;
    if (r.code == 1) {
      ++failed;
      // "cannot write <out>/continuum/continuum_0000.0.vtu: File too large (writing)", or the
      // run directory's own files at the smallest limit
      EXPECT_NE(r.out.find("cannot write "), std::string::npos) << context << "\n" << r.out;
      EXPECT_NE(r.out.find(out.string()), std::string::npos) << context << "\n" << r.out;
      EXPECT_NE(r.out.find("File too large"), std::string::npos) << context << "\n" << r.out;
      EXPECT_EQ(r.out.find("filesystem error"), std::string::npos) << r.out;
      continue;
    }
    ++passed;
    const fs::path dir = out / "continuum";
    for (const char* csv : {"structures.csv", "steps.csv", "surface_profile.csv"}) {
      const auto b = slurp(dir / csv);
      EXPECT_TRUE(b.size() > 20 && b.back() == '\n') << context << ": " << csv;
    }
    const auto pvd = slurp(dir / "continuum.pvd");
    EXPECT_NE(pvd.find("</VTKFile>"), std::string::npos) << context;
    int records = 0;
    for (auto pos = pvd.find("file=\""); pos != std::string::npos;
         pos = pvd.find("file=\"", pos + 6)) {
      const auto pvtu = dir / pvd.substr(pos + 6, pvd.find('"', pos + 6) - pos - 6);
      const auto rec = slurp(pvtu);
      EXPECT_NE(rec.find("</VTKFile>"), std::string::npos) << context << ": " << pvtu;
      for (auto q = rec.find("Source=\""); q != std::string::npos;
           q = rec.find("Source=\"", q + 8)) {
        const auto piece = dir / rec.substr(q + 8, rec.find('"', q + 8) - q - 8);
        EXPECT_NE(slurp(piece).find("</VTKFile>"), std::string::npos) << context << ": " << piece;
      }
      ++records;
    }
    EXPECT_EQ(records, 4) << context; // t = 0, 0.02, 0.04, 0.06
  }
  EXPECT_GE(failed, 1);
  EXPECT_GE(passed, 1);
}
#endif
