// The run directory is demfem's and says what it holds: demfem never deletes or overwrites a file
// it did not write (the manifest in .demfem/), one command at a time writes into a folder (the
// lock), names cannot leave the output folder, a resume continues only the computation its
// checkpoint belongs to, a comparison with a failed or short solver run fails, every command
// stops cleanly on a stop signal, and a write past the file size limit is an error, not SIGXFSZ.
#include <sys/file.h>

#include <chrono>
#include <csignal>
#include <fcntl.h>
#include <filesystem>
#include <string>
#include <thread>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_util.hpp"

namespace fs = std::filesystem;
using namespace demfem::test;

namespace {

const fs::path kSource = DEMFEM_SOURCE_DIR;

// The settle-box scene (120 disks, a footing, probes and VTK snapshots) for `duration` seconds,
// without figures, with extra TOML appended (e.g. variants).
fs::path settle_box(const std::string& name, double duration, const std::string& extra = {}) {
  auto text = with_values(slurp(kSource / "cases/verification/settle_box.toml"),
                          {{"duration", std::to_string(duration)}});
  const auto pos = text.find("\n[output]\n");
  if (pos != std::string::npos) text.insert(pos + 10, "figures = false\n");
  return write_temp("rundir_" + name + ".toml", text + extra);
}

// Every file under dir (recursively) with its bytes, the .demfem records included.
std::map<std::string, std::string> snapshot(const fs::path& dir) {
  std::map<std::string, std::string> m;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    m[fs::relative(e.path(), dir).string()] = e.is_regular_file() ? slurp(e.path()) : "<dir>";
  return m;
}

// True while another process holds the folder's lock.
bool locked(const fs::path& dir) {
  const int fd = ::open((dir / ".demfem" / "lock").c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0;
  ::close(fd);
  return held;
}

// Waits (polling) until `ready()` or the child has exited; true when ready.
template <class F> bool wait_for(Child& c, F ready) {
  while (c.running()) {
    if (ready()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return ready();
}

bool file_longer_than(const fs::path& f, std::uintmax_t n) {
  std::error_code ec;
  const auto s = fs::file_size(f, ec);
  return !ec && s > n;
}

} // namespace

// A folder demfem did not make is never written into, --force or not: a user's folder (or
// `--out .`) and a run directory of an older demfem (no manifest) are refused with exit 2,
// naming what is there, and keep every byte.
TEST(RunDirOwnership, FoldersDemfemDidNotMakeAreRefusedEvenWithForce) {
  const auto scene = settle_box("own", 0.05);
  const fs::path user = scratch("user");
  fs::create_directories(user / "figures");
  std::ofstream(user / "figures" / "mine.png") << "my figure";
  std::ofstream(user / "summary.json") << "{\"mine\": 1}\n";
  const auto before = snapshot(user);
  for (const char* force : {"", " --force"}) {
    const auto r = run("run " + scene.string() + " --out " + user.string() + force);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find("figures/, summary.json"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--force does not change that"), std::string::npos) << r.out;
    EXPECT_EQ(snapshot(user), before) << "a refused run touched the folder" << force;
  }
  // `--out .` in the user's folder
  const auto dot = run_raw("cd " + user.string() + " && " + DEMFEM_BINARY + " run " +
                           scene.string() + " --out . --force");
  EXPECT_EQ(dot.code, 2) << dot.out;
  EXPECT_EQ(snapshot(user), before);

  // A run directory as an older demfem left it: refused, with what to do; nothing deleted.
  const fs::path old = scratch("old");
  fs::create_directories(old / "dem");
  std::ofstream(old / "dem" / "energy.csv") << "time [s]\n0\n";
  std::ofstream(old / "scene.resolved.toml") << "# resolved scene: settle-box\n";
  std::ofstream(old / "log.txt") << "log\n";
  const auto old_before = snapshot(old);
  const auto r = run("run " + scene.string() + " --out " + old.string() + " --force");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("older demfem"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("mv " + old.string()), std::string::npos) << r.out;
  EXPECT_EQ(snapshot(old), old_before);
  fs::remove(scene);
}

// In a folder demfem made, a re-run and --force delete only what the manifest lists; a file the
// user added is kept, and one the command would overwrite is refused.
TEST(RunDirOwnership, RerunAndForceDeleteOnlyWhatTheManifestLists) {
  const auto a = settle_box("list_a", 0.05);
  const auto b =
      write_temp("rundir_list_b.toml",
                 with_values(slurp(kSource / "cases/verification/rebounding_settle.toml"),
                             {{"duration", "0.05"}}));
  const fs::path out = scratch("listed");
  ASSERT_EQ(run("run " + a.string() + " --out " + out.string()).code, 0);
  const auto manifest = slurp(out / ".demfem" / "manifest.txt");
  for (const char* n : {"\ndem\n", "\nlog.txt\n", "\nrun_dem.json\n", "\nscene.resolved.toml\n"})
    EXPECT_NE(manifest.find(n), std::string::npos) << n << " not in\n" << manifest;
  for (const auto& e : fs::directory_iterator(out)) // everything the run wrote is listed
    EXPECT_TRUE(e.path().filename() == ".demfem" ||
                manifest.find("\n" + e.path().filename().string() + "\n") != std::string::npos)
        << e.path();
  fs::create_directories(out / "mine");
  std::ofstream(out / "mine" / "notes.txt") << "mine";
  std::ofstream(out / "notes.txt") << "mine";
  EXPECT_EQ(run("run " + a.string() + " --out " + out.string()).code, 0);
  const auto forced = run("run " + b.string() + " --out " + out.string() + " --force");
  ASSERT_EQ(forced.code, 0) << forced.out;
  EXPECT_EQ(slurp(out / "notes.txt"), "mine");
  EXPECT_EQ(slurp(out / "mine" / "notes.txt"), "mine");
  // report.html is not the DEM run's: a user's report.html there is not overwritten by compare
  std::ofstream(out / "report.html") << "my report";
  const auto cmp = run("compare " + b.string() + " --out " + out.string());
  EXPECT_EQ(cmp.code, 2) << cmp.out;
  EXPECT_NE(cmp.out.find("report.html"), std::string::npos) << cmp.out;
  EXPECT_EQ(slurp(out / "report.html"), "my report");
  fs::remove(a);
  fs::remove(b);
}

// Names are folder names: a variant or scene name that is absolute, '.', '..' or holds '/' is
// refused (exit 2) before anything is written, and nothing lands outside --out or runs/.
TEST(RunDirOwnership, NamesCannotLeaveTheOutputFolder) {
  const fs::path base = scratch("names");
  const fs::path out = base / "out";
  const std::string abs = "/tmp/demfem-escape-" + std::to_string(::getpid());
  for (const std::string& bad : std::vector<std::string>{"../escape", "..", abs}) {
    SCOPED_TRACE(bad);
    const auto scene = settle_box(
        "names", 0.05,
        "\n[[variant]]\nname = \"ok\"\nset = { \"scene.duration\" = 0.05 }\n[[variant]]\nname "
        "= \"" +
            bad + "\"\nset = { \"scene.duration\" = 0.04 }\n");
    const auto r = run("run " + scene.string() + " --all-variants --out " + out.string());
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_FALSE(fs::exists(base / "escape"));
    EXPECT_FALSE(fs::exists(abs));
    EXPECT_FALSE(fs::exists(out / "ok" / "dem")) << "a refused command ran something";
  }
  // a scene name into the default runs/<name>
  const auto named = write_temp(
      "rundir_named.toml", with_values(slurp(settle_box("named0", 0.05)), {{"name", "\"../x\""}}));
  const auto r = run_raw("cd " + base.string() + " && " + DEMFEM_BINARY + " run " + named.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_FALSE(fs::exists(base / "x"));
}

// Two runs into one folder: the second is refused with exit 2 naming the first's PID, and the
// first's outputs are untouched; the lock of a run killed with SIGKILL is taken over.
TEST(RunDirLock, SecondRunIntoTheSameFolderIsRefused) {
  const auto long_run = settle_box("lock", 20.0);
  const auto other = settle_box("lock_other", 0.05);
  const fs::path out = scratch("locked");
  {
    Child first({"run", long_run.string(), "--out", out.string()}, out.string() + ".log");
    ASSERT_TRUE(first.started());
    ASSERT_TRUE(wait_for(first, [&] { return file_longer_than(out / "dem" / "energy.csv", 2000); }))
        << first.wait().out;
    for (const auto& scene : {other, long_run}) {
      const auto r = run("run " + scene.string() + " --out " + out.string());
      EXPECT_EQ(r.code, 2) << r.out;
      EXPECT_NE(r.out.find("is in use"), std::string::npos) << r.out;
      EXPECT_NE(r.out.find("PID " + std::to_string(first.pid())), std::string::npos) << r.out;
    }
    first.signal(SIGKILL); // a stale lock: its holder died
    first.wait();
  }
  EXPECT_NE(slurp(out / ".demfem" / "lock"), "") << "the dead run's PID stays in the file";
  const auto again = run("run " + long_run.string() + " --out " + out.string() + " --resume");
  EXPECT_NE(again.code, 2) << again.out; // taken over (the resume itself may find no checkpoint)
  const auto fresh = run("run " + other.string() + " --out " + out.string() + " --force");
  EXPECT_EQ(fresh.code, 0) << fresh.out;
  EXPECT_EQ(slurp(out / ".demfem" / "lock"), "") << "the PID goes with the lock";
  fs::remove(out.string() + ".log");
}

// --resume checks the content: a scene with other values (K_n ×3, μ) or another DEM engine is
// refused with exit 2 naming the first differing key, and the refused command changes nothing
// in the folder; the unchanged scene then resumes to the end. A longer duration may resume.
TEST(RunDirResume, ChangedSceneOrEngineIsRefusedAndChangesNothing) {
  const auto scene = settle_box("resume", 8.0);
  const fs::path out = scratch("resume");
  {
    Child c({"run", scene.string(), "--out", out.string()}, out.string() + ".log");
    ASSERT_TRUE(wait_for(c, [&] { return file_longer_than(out / "dem" / "energy.csv", 2000); }));
    c.signal(SIGTERM);
    ASSERT_EQ(c.wait().code, 3);
  }
  const auto changed = write_temp(
      "rundir_resume_changed.toml",
      with_values(slurp(scene), {{"kn", "3.0e6"}, {"mu_static", "0.6"}, {"duration", "8.0"}}));
  const auto before = snapshot(out);
  const auto r = run("run " + changed.string() + " --out " + out.string() + " --resume");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("soil.dem.kn = 3000000.0 here, 1000000.0 there"), std::string::npos)
      << r.out;
  EXPECT_EQ(snapshot(out), before) << "a refused --resume changed the folder";
  // the same scene, as if run by another DEM engine
  const fs::path rec = out / ".demfem" / "dem.toml";
  const std::string rec_text = slurp(rec);
  const auto at = rec_text.find("# DEM engine fingerprint: ");
  ASSERT_NE(at, std::string::npos) << rec_text;
  std::string other_engine = rec_text;
  other_engine.replace(at, rec_text.find('\n', at) - at,
                       "# DEM engine fingerprint: 0123456789abcdef");
  std::ofstream(rec) << other_engine;
  const auto e = run("run " + scene.string() + " --out " + out.string() + " --resume");
  EXPECT_EQ(e.code, 2) << e.out;
  EXPECT_NE(e.out.find("DEM engine 0123456789abcdef"), std::string::npos) << e.out;
  std::ofstream(rec) << rec_text;
  // the original scene's own resume is accepted (the refused command did not rewrite the
  // folder's scene) and runs to the end, also with a longer duration
  const auto ok = run("run " + scene.string() + " --out " + out.string() + " --resume");
  EXPECT_EQ(ok.code, 0) << ok.out;
  const auto longer =
      write_temp("rundir_resume_longer.toml", with_values(slurp(scene), {{"duration", "8.5"}}));
  EXPECT_EQ(run("run " + longer.string() + " --out " + out.string() + " --resume").code, 0);
  fs::remove(out.string() + ".log");
}

// A record the run cannot write is a failed run (exit 1 naming the file), not a warning.
TEST(RunDirRecords, UnwritableRunRecordFailsTheRun) {
  const auto scene = settle_box("record", 0.05);
  const fs::path out = scratch("record");
  ASSERT_EQ(run("run " + scene.string() + " --out " + out.string()).code, 0);
  // a resume of the finished run (it continues from the end) cannot replace its record: a
  // folder stands in its place
  fs::remove(out / "run_dem.json");
  fs::create_directories(out / "run_dem.json" / "x");
  const auto r = run("run " + scene.string() + " --out " + out.string() + " --resume");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("cannot write " + (out / "run_dem.json").string()), std::string::npos)
      << r.out;
  for (const auto& [name, bytes] : files_under(out))
    EXPECT_NE(fs::path(name).extension(), ".tmp") << name;
}

// demfem ignores SIGXFSZ itself: under `ulimit -f` with the signal's default action (as a shell
// leaves it) a write past the limit is reported ("File too large", exit 1) and leaves no .tmp.
TEST(RunDirRecords, FileSizeLimitIsAnErrorNotSigxfsz) {
  const auto scene = settle_box("xfsz", 0.3);
  // at 3000 bytes the run's first record fails; at 12000 its second particle snapshot
  for (const long long limit : {3000LL, 12000LL}) {
    const fs::path out = scratch("xfsz_" + std::to_string(limit));
    Child c({"run", scene.string(), "--out", out.string()}, out.string() + ".log", limit,
            /*ignore_sigxfsz=*/false);
    const auto r = c.wait();
    EXPECT_EQ(r.code, 1) << "limit " << limit << ": " << r.out;
    EXPECT_NE(r.out.find("File too large"), std::string::npos) << r.out;
    for (const auto& [name, bytes] : files_under(out))
      EXPECT_NE(fs::path(name).extension(), ".tmp") << name;
    fs::remove(out.string() + ".log");
  }
}

// SIGTERM to `run --jobs`: each running child stops at a checkpoint, none starts after, the
// command exits 3 with the commands that continue; after SIGKILL of the parent the children
// stop too (no orphan runs on).
TEST(RunDirSignals, RunJobsStopsItsChildren) {
  const std::string variants = "\n[[variant]]\nname = \"a\"\nset = { \"soil.dem.kn\" = 2.0e6 }\n"
                               "[[variant]]\nname = \"b\"\nset = { \"soil.dem.kn\" = 3.0e6 }\n"
                               "[[variant]]\nname = \"c\"\nset = { \"soil.dem.kn\" = 4.0e6 }\n";
  const auto scene = settle_box("jobs", 20.0, variants);
  for (const int sig : {SIGTERM, SIGKILL}) {
    SCOPED_TRACE(sig == SIGTERM ? "SIGTERM" : "SIGKILL");
    const fs::path out = scratch(sig == SIGTERM ? "jobs_term" : "jobs_kill");
    Child c({"run", scene.string(), "--all-variants", "--jobs", "2", "--out", out.string()},
            out.string() + ".log");
    // the two largest (c, b) run first
    ASSERT_TRUE(wait_for(c, [&] {
      return file_longer_than(out / "c" / "dem" / "energy.csv", 2000) &&
             file_longer_than(out / "b" / "dem" / "energy.csv", 2000);
    })) << c.wait().out;
    c.signal(sig);
    const auto r = c.wait();
    if (sig == SIGTERM) {
      EXPECT_EQ(r.code, 3) << r.out;
      EXPECT_NE(r.out.find("--variant c --out " + (out / "c").string() + " --resume"),
                std::string::npos)
          << r.out;
      EXPECT_NE(r.out.find("a: not started"), std::string::npos) << r.out;
    }
    for (const char* v : {"b", "c"}) {
      while (locked(out / v)) // a child holds its run directory's lock while it runs
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      EXPECT_TRUE(fs::exists(out / v / "dem" / "checkpoint.ckpt")) << v;
      EXPECT_FALSE(fs::exists(out / v / "dem" / "final.ckpt")) << v << " ran on to the end";
      EXPECT_NE(slurp(out / v / "console.txt").find("stopped by SIGTERM"), std::string::npos)
          << slurp(out / v / "console.txt");
    }
    EXPECT_FALSE(fs::exists(out / "a" / "dem")) << "a started after the stop";
    fs::remove(out.string() + ".log");
  }
}

// A study (stability: in-process DEM rows; error-vs-time: child processes) stops at SIGTERM with
// exit 3 and writes no study page over a partial sweep.
TEST(RunDirSignals, StudyStopsWithExit3) {
  const auto scene = settle_box("study", 5.0);
  const fs::path out = scratch("study");
  Child c({"study", "stability", scene.string(), "--out", out.string()}, out.string() + ".log");
  ASSERT_TRUE(wait_for(c, [&] {
    std::error_code ec;
    if (!fs::is_directory(out / "rows", ec)) return false;
    for (const auto& e : fs::directory_iterator(out / "rows", ec))
      if (file_longer_than(e.path() / "dem" / "energy.csv", 2000)) return true;
    return false;
  })) << c.wait().out;
  c.signal(SIGTERM);
  const auto r = c.wait();
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_NE(r.out.find("run it again"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out / "study.json"));
  fs::remove(out.string() + ".log");

  // error-vs-time: its runs are child processes; the first one's log appears, then SIGTERM
  const fs::path ev = scratch("study_ev");
  Child e({"study", "error-vs-time",
           (kSource / "cases/verification/head_on_collision.toml").string(), "--repeats", "3",
           "--jobs", "1", "--out", ev.string()},
          ev.string() + ".log");
  ASSERT_TRUE(wait_for(e, [&] {
    std::error_code ec;
    for (const auto& f : fs::recursive_directory_iterator(ev / "runs", ec))
      if (f.path().extension() == ".log") return true;
    return false;
  })) << e.wait().out;
  e.signal(SIGTERM);
  const auto re = e.wait();
  EXPECT_EQ(re.code, 3) << re.out;
  EXPECT_NE(re.out.find("the study was not written"), std::string::npos) << re.out;
  EXPECT_FALSE(fs::exists(ev / "study.json"));
  fs::remove(ev.string() + ".log");
}

// A calibration stops at SIGTERM in its element tests with exit 3, the command that starts it
// again, and no calibration written.
TEST(RunDirSignals, CalibrateStopsWithExit3) {
  const fs::path out = scratch("calibrate_stop");
  const auto scene = write_temp(
      "rundir_calibrate.toml",
      "[scene]\nname = \"tiny\"\nduration = 1\nseed = 3\nsolvers = [\"dem\", \"continuum\"]\n"
      "[domain]\npolygon = [[0, 0], [1.2, 0], [1.2, 0.8], [0, 0.8]]\n"
      "[soil.dem]\ncount = 200\nradius = { uniform = [0.015, 0.025] }\nkn = 1.0e6\n"
      "ks = 3.0e5\n[soil.dem.packing]\ndamping = 0.05\nmax_time = 10\n"
      "[soil.continuum]\ncalibrate = \"dem\"\n"
      "[[wall]]\nname = \"base\"\npoints = [[0, 0], [1.2, 0]]\n"
      "[[wall]]\nname = \"left\"\npoints = [[0, 0.8], [0, 0]]\n"
      "[[wall]]\nname = \"right\"\npoints = [[1.2, 0], [1.2, 0.8]]\n");
  const fs::path log = out.string() + ".log";
  Child c({"calibrate", scene.string(), "--particles", "100", "--no-cyclic", "--out", out.string()},
          log);
  ASSERT_TRUE(wait_for(c, [&] { return slurp(log).find("[calibrate: ") != std::string::npos; }))
      << c.wait().out;
  c.signal(SIGTERM);
  const auto r = c.wait();
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_NE(r.out.find("stopped by SIGTERM"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("run it again:\n  demfem calibrate"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out / "calibration.json"));
  fs::remove(log);
}

#ifdef DEMFEM_TEST_CONTINUUM
namespace {
// Two disks on a floor and an elastic continuum box: both solvers in about a second.
std::string tiny_compare(double duration) {
  return R"(
[scene]
name = "tiny-honest"
solvers = ["dem", "continuum"]
duration = )" +
         std::to_string(duration) +
         R"(
[domain]
polygon = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.3], [0.0, 0.3]]
[soil.dem]
count = 2
radius = { equal = 0.05 }
density = 2650
kn = 1.0e6
ks = 3.0e5
particles = [[0.3, 0.051, 0.05, 0.0, 0.0, 0.0], [0.6, 0.051, 0.05, 0.0, 0.0, 0.0]]
[soil.continuum]
model = "elastic"
young = 3.0e7
poisson = 0.3
density = 1700
k0 = 0.5
[continuum]
refinement = 0
degree = 1
dt = 0.01
linear_solver = "direct"
[[wall]]
name = "base"
points = [[0.0, 0.0], [1.0, 0.0]]
[load]
gravity = 9.81
[[probe]]
kind = "energy"
[output]
vtk = false
figures = false
probe_interval = 0.01
)";
}
} // namespace

// compare exits 1 when a solver failed (a missing continuum module) or its series end before the
// scene's duration, and says so in the report and in metrics.json ("incomplete"); so does
// --report-only, from the run records.
TEST(RunDirCompare, FailedOrShortSolverRunsFailTheComparison) {
  const auto scene = write_temp("rundir_honest.toml", tiny_compare(0.05));
  const fs::path out = scratch("honest");
  const auto ok = run("compare " + scene.string() + " --out " + out.string());
  ASSERT_EQ(ok.code, 0) << ok.out;
  EXPECT_FALSE(nlohmann::json::parse(slurp(out / "metrics.json")).contains("incomplete"));

  const fs::path nomod = scratch("honest_nomod");
  const auto m = run_raw("DEMFEM_CONTINUUM_MODULE=/nonexistent " + std::string(DEMFEM_BINARY) +
                         " compare " + scene.string() + " --out " + nomod.string());
  EXPECT_EQ(m.code, 1) << m.out;
  const auto mj = nlohmann::json::parse(slurp(nomod / "metrics.json"));
  ASSERT_TRUE(mj.contains("incomplete")) << mj.dump(1);
  EXPECT_NE(mj["incomplete"][0].get<std::string>().find("continuum"), std::string::npos);
  EXPECT_NE(slurp(nomod / "report.html").find("Incomplete:"), std::string::npos);

  // --report-only on a continuum run that stopped at 0.02 s of 0.05 s
  const fs::path rec = out / "run_continuum.json";
  auto j = nlohmann::json::parse(slurp(rec));
  j["simulated_time_s"] = 0.02;
  std::ofstream(rec) << j.dump(1);
  const auto short_run =
      run("compare " + scene.string() + " --out " + out.string() + " --report-only");
  EXPECT_EQ(short_run.code, 1) << short_run.out;
  const auto sj = nlohmann::json::parse(slurp(out / "metrics.json"));
  ASSERT_TRUE(sj.contains("incomplete")) << sj.dump(1);
  EXPECT_NE(sj["incomplete"][0].get<std::string>().find("end at t = 0.02 s"), std::string::npos)
      << sj["incomplete"].dump();
  // a DEM run that did not finish: no record
  fs::remove(out / "run_dem.json");
  const auto unfinished =
      run("compare " + scene.string() + " --out " + out.string() + " --report-only");
  EXPECT_EQ(unfinished.code, 1) << unfinished.out;
  EXPECT_NE(unfinished.out.find("the dem run did not finish"), std::string::npos) << unfinished.out;
}

// SIGINT, SIGTERM and SIGHUP stop an implicit continuum run after its current step with exit 3
// and a message that it cannot resume, with the command that runs it again (an explicit run
// writes a checkpoint: test_continuum_resume.cpp).
TEST(RunDirSignals, ContinuumRunStopsWithExit3) {
  const auto scene =
      write_temp("rundir_footing.toml",
                 with_values(slurp(kSource / "cases/verification/continuum_footing_load.toml"),
                             {{"duration", "5.0"}}));
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
    SCOPED_TRACE(sig);
    const fs::path out = scratch("continuum_stop_" + std::to_string(sig));
    Child c({"run", scene.string(), "--solver", "continuum", "--out", out.string()},
            out.string() + ".log");
    ASSERT_TRUE(wait_for(c, [&] { return file_longer_than(out / "continuum" / "steps.csv", 400); }))
        << c.wait().out;
    c.signal(sig);
    const auto r = c.wait();
    EXPECT_EQ(r.code, 3) << r.out;
    EXPECT_NE(r.out.find("cannot resume (the implicit"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--solver continuum --out " + out.string() + "\n"), std::string::npos)
        << r.out;
    EXPECT_FALSE(fs::exists(out / "run_continuum.json")) << "a stopped run recorded as done";
    fs::remove(out.string() + ".log");
  }
}
#endif
