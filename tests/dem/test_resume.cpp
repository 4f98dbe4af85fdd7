// Checkpoints and resume (a resumed run equals an uninterrupted one bit for bit at the same thread
// count), the interrupt flag, and deterministic OpenMP force loops.
#include <gtest/gtest.h>

#include "../scratch.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <tuple>

#include "demfem/app/vocabulary.hpp"
#include "demfem/dem/cpu_idle.hpp"
#include "demfem/dem/engine.hpp"
#include "demfem/dem/io.hpp"
#include "demfem/dem/pack.hpp"
#include "demfem/dem/run.hpp"
#include "demfem/scene/load.hpp"

#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

using namespace demfem;

namespace {

std::filesystem::path scratch(const std::string& name) {
  return demfem::test::scratch(name);
}

std::string slurp(const std::filesystem::path& f) {
  std::ifstream in(f, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The settle-box scene (120 disks, friction, cundall-rebound, a free footing, recorded base
// wall) with a set-friction event at 0.12 s, pressure-profile, loci and coordination probes.
scene::Scene resume_scene(double duration) {
  const auto file = scene::load_scene_file(DEMFEM_SOURCE_DIR "/cases/verification/settle_box.toml",
                                           demfem::app::vocabulary());
  auto sc = file.base;
  sc.info.duration = duration;
  sc.output.interval = 0.1;
  sc.output.probe_interval = 0.01;
  sc.groups.push_back({"left_half", {{0, 0}, {0.5, 0}, {0.5, 1}, {0, 1}}});
  scene::Event ev;
  ev.time = 0.12;
  ev.action = scene::EventAction::SetFriction;
  ev.group = "left_half";
  ev.mu_static = 0.1;
  ev.mu_dynamic = 0.05;
  sc.events.push_back(ev);
  scene::Probe pp;
  pp.kind = scene::ProbeKind::PressureProfile;
  pp.target = "left";
  pp.bins = 5;
  sc.probes.push_back(pp);
  scene::Probe lp;
  lp.kind = scene::ProbeKind::Loci;
  lp.points = {{0.3, 0.2}, {0.7, 0.4}};
  sc.probes.push_back(lp);
  return sc;
}

const char* kCsvFiles[] = {"energy.csv",  "structures.csv", "walls.csv",       "pressure_left.csv",
                           "surface.csv", "loci.csv",       "coordination.csv"};

void expect_same_particles(const dem::Particles& a, const dem::Particles& b) {
  ASSERT_EQ(a.size(), b.size());
  auto same = [](const auto& u, const auto& v) {
    return u.size() == v.size() && std::memcmp(u.data(), v.data(), u.size() * sizeof(u[0])) == 0;
  };
  EXPECT_TRUE(same(a.x, b.x));
  EXPECT_TRUE(same(a.z, b.z));
  EXPECT_TRUE(same(a.phi, b.phi));
  EXPECT_TRUE(same(a.vx, b.vx));
  EXPECT_TRUE(same(a.vz, b.vz));
  EXPECT_TRUE(same(a.omega, b.omega));
  EXPECT_TRUE(same(a.fx, b.fx));
  EXPECT_TRUE(same(a.fz, b.fz));
  EXPECT_TRUE(same(a.torque, b.torque));
  EXPECT_TRUE(same(a.id, b.id));
  EXPECT_TRUE(same(a.material, b.material));
  EXPECT_TRUE(same(a.flags, b.flags));
}

void expect_same_outputs(const std::filesystem::path& a, const std::filesystem::path& b) {
  for (const char* f : kCsvFiles) {
    ASSERT_TRUE(std::filesystem::exists(a / "dem" / f)) << f;
    const auto ta = slurp(a / "dem" / f), tb = slurp(b / "dem" / f);
    EXPECT_GT(ta.size(), 100u) << f;
    EXPECT_TRUE(ta == tb) << f << " differs";
  }
  for (const char* f : {"particles.pvd", "boundaries.pvd", "force_chains.pvd"})
    EXPECT_EQ(slurp(a / "dem" / f), slurp(b / "dem" / f)) << f;
  const auto ca = dem::io::read_checkpoint(a / "dem" / "final.ckpt");
  const auto cb = dem::io::read_checkpoint(b / "dem" / "final.ckpt");
  EXPECT_EQ(ca.meta.step, cb.meta.step);
  EXPECT_EQ(ca.meta.time, cb.meta.time);
  expect_same_particles(ca.particles, cb.particles);
}

} // namespace

// (a) 0.3 s straight vs 0.15 s + end checkpoint + resume to 0.3 s: every particle array and every
// probe CSV identical. The split point (step 826) falls between two probe rows, after the friction
// event's region is set up and before it fires.
TEST(DemResume, ResumedRunEqualsUninterruptedBitForBit) {
  dem::RunOptions a;
  a.out_dir = scratch("straight");
  a.threads = 1;
  const auto sa = dem::run(resume_scene(0.3), a);
  ASSERT_TRUE(sa.ok) << sa.message;

  dem::RunOptions b = a;
  b.out_dir = scratch("split");
  const auto s1 = dem::run(resume_scene(0.1537), b);
  ASSERT_TRUE(s1.ok) << s1.message;
  ASSERT_TRUE(std::filesystem::exists(b.out_dir / "dem" / "checkpoint.ckpt"));
  b.resume = true;
  const auto s2 = dem::run(resume_scene(0.3), b);
  ASSERT_TRUE(s2.ok) << s2.message;
  EXPECT_EQ(s2.steps, sa.steps);
  expect_same_outputs(a.out_dir, b.out_dir);
  // The event fired in the second half: its material is in the final state.
  const auto c = dem::io::read_checkpoint(b.out_dir / "dem" / "final.ckpt");
  bool any_new_material = false;
  for (auto m : c.particles.material) any_new_material |= m != 0;
  EXPECT_TRUE(any_new_material);
}

// Periodic checkpoints do not perturb the run, and a resume from the last periodic one
// reproduces the rest.
TEST(DemResume, PeriodicCheckpointsAndResumeFromThem) {
  dem::RunOptions a;
  a.out_dir = scratch("straight2");
  a.threads = 1;
  ASSERT_TRUE(dem::run(resume_scene(0.2), a).ok);
  auto sc = resume_scene(0.2);
  sc.output.checkpoint_interval = 0.05;
  dem::RunOptions b = a;
  b.out_dir = scratch("periodic");
  const auto s1 = dem::run(sc, b);
  ASSERT_TRUE(s1.ok) << s1.message;
  expect_same_outputs(a.out_dir, b.out_dir);
  // Resuming a finished run (checkpoint at its end) rewrites the final outputs identically.
  b.resume = true;
  const auto s2 = dem::run(sc, b);
  ASSERT_TRUE(s2.ok) << s2.message;
  expect_same_outputs(a.out_dir, b.out_dir);
}

// (b) The interrupt flag: the loop writes a checkpoint and returns ok = false with the message;
// a resume completes the run, identical to an uninterrupted one.
TEST(DemResume, InterruptFlagWritesResumableCheckpoint) {
  dem::RunOptions a;
  a.out_dir = scratch("straight3");
  a.threads = 1;
  ASSERT_TRUE(dem::run(resume_scene(0.2), a).ok);

  dem::RunOptions b = a;
  b.out_dir = scratch("interrupted");
  std::atomic<bool> stop{false};
  b.interrupt = &stop;
  // Set from the progress callback (its first report comes before the first step).
  b.progress = [&](const scene::Progress&) { stop = true; };
  const auto s1 = dem::run(resume_scene(0.2), b);
  EXPECT_FALSE(s1.ok);
  EXPECT_NE(s1.message.find("interrupted at t = "), std::string::npos) << s1.message;
  EXPECT_NE(s1.message.find("continue with --resume"), std::string::npos) << s1.message;
  ASSERT_TRUE(std::filesystem::exists(b.out_dir / "dem" / "checkpoint.ckpt"));
  EXPECT_FALSE(std::filesystem::exists(b.out_dir / "dem" / "final.ckpt"));
  stop = false;
  b.resume = true;
  b.progress = {};
  const auto s2 = dem::run(resume_scene(0.2), b);
  ASSERT_TRUE(s2.ok) << s2.message;
  expect_same_outputs(a.out_dir, b.out_dir);
}

// A resume refuses a checkpoint of another scene and a missing checkpoint.
TEST(DemResume, RefusesMissingOrForeignCheckpoint) {
  dem::RunOptions b;
  b.out_dir = scratch("foreign");
  b.resume = true;
  auto s = dem::run(resume_scene(0.05), b);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("cannot resume"), std::string::npos) << s.message;
  b.resume = false;
  ASSERT_TRUE(dem::run(resume_scene(0.05), b).ok);
  auto other = resume_scene(0.05);
  other.info.name = "another-scene";
  b.resume = true;
  s = dem::run(other, b);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("another-scene"), std::string::npos) << s.message;
}

// Engine level: save_state/restore_state on a freshly built engine continues bit for bit, through
// a reorder (reorder_every = 2) and an opened wall.
TEST(DemResume, EngineStateRoundTrip) {
  for (const int threads : {1, 2}) { // bit for bit at the same thread count
    auto build = [threads] {
      dem::EngineConfig c;
      c.law = dem::contact::make_law("cundall-rebound", {{"kn", 1e6}, {"ks", 3e5}});
      c.reorder_every = 2;
      c.shaking = true;
      c.shaking_acceleration = scene::TimeFunction::sine(2.0, 3.0);
      c.threads = threads;
      c.parallel_min_particles = 0;
      auto e = std::make_unique<dem::Engine>(c);
      e->add_wall({{0, 2}, {0, 0}, {1, 0}, {1, 2}}, "box");
      e->add_wall({{0.3, 0.995}, {0.7, 0.995}}, "shelf");
      return e;
    };
    auto e1 = build();
    std::mt19937_64 g(7);
    for (int k = 0; k < 200; ++k)
      e1->add_particle(0.05 + 0.09 * (k % 10), 0.05 + 0.09 * (k / 10),
                       0.03 + 0.01 * static_cast<double>(g() >> 11) * 0x1.0p-53);
    e1->set_dt(e1->auto_dt());
    e1->run_steps(1500);
    e1->open_wall("shelf");
    e1->set_friction({{0, 0}, {0.5, 0}, {0.5, 2}, {0, 2}}, 0.2, 0.1);
    e1->run_steps(500);
    auto e2 = build();
    e2->restore_state(e1->particles(), e1->save_state());
    EXPECT_GT(e1->stats().reorders, 0);
    EXPECT_EQ(e1->threads_in_use(), threads);
    e1->run_steps(1000);
    e2->run_steps(1000);
    ASSERT_FALSE(e1->failed()) << e1->failure();
    expect_same_particles(e1->particles(), e2->particles());
    EXPECT_EQ(e1->energy().total(), e2->energy().total());
    EXPECT_EQ(e1->stats().neighbour_rebuilds, e2->stats().neighbour_rebuilds);
  }
}

namespace {
// n disks (r 0.04–0.075 m) on a lattice of `cols` columns in a box, random velocities ±1 m/s
// (collisions everywhere at once), automatic Δt.
void add_shaken_lattice(dem::Engine& e, int n, int cols, std::uint64_t seed) {
  e.add_wall({{0, 10}, {0, 0}, {cols * 0.151 + 0.01, 0}, {cols * 0.151 + 0.01, 10}}, "box");
  std::mt19937_64 g(seed);
  auto u = [&] { return static_cast<double>(g() >> 11) * 0x1.0p-53; };
  for (int k = 0; k < n; ++k) {
    const double r = 0.04 + 0.035 * u();
    e.add_particle(0.08 + 0.151 * (k % cols), 0.08 + 0.151 * (k / cols), r, 2 * u() - 1,
                   2 * u() - 1);
  }
  e.set_dt(e.auto_dt());
}

// A rigid lid over [x0, x1] × [z0, z1], every degree of freedom fixed (the default).
void add_lid(dem::Engine& e, double x0, double x1, double z0, double z1) {
  scene::Structure lid;
  lid.name = "lid";
  lid.outline = {{x0, z0}, {x1, z0}, {x1, z1}, {x0, z1}};
  lid.pivot = {0.5 * (x0 + x1), z0};
  lid.load_point = {0.5 * (x0 + x1), z1};
  lid.density = 2400;
  e.add_structure(lid);
}
} // namespace

// OpenMP: 2 threads give bit-identical results across runs and agree with 1 thread to round-off.
TEST(DemThreads, TwoThreadsDeterministicAndCloseToOne) {
  auto run = [](int threads) {
    dem::EngineConfig c;
    c.law = dem::contact::make_law("cundall-rebound", {{"kn", 1e7}, {"ks", 3e6}});
    c.damping_c = 2.0;
    c.threads = threads;
    c.parallel_min_particles = 0;
    dem::Engine e(c);
    // 2000 disks on a lattice with random velocities (±1 m/s): collisions everywhere at once.
    add_shaken_lattice(e, 2000, 50, 1);
    e.run_steps(600);
    EXPECT_FALSE(e.failed()) << e.failure();
    std::vector<dem::ContactView> cv;
    e.contacts(cv);
    EXPECT_GT(cv.size(), 30u);          // the pair loop is exercised: contacts now,
    EXPECT_GT(e.energy().rebound, 1.0); // and many collisions before
    EXPECT_EQ(e.threads_in_use(), threads);
    // The box's reaction: each part sums its particles' wall contacts, added in part order.
    const auto& box = e.boundaries()[0];
    EXPECT_LT(box.reaction_z, 0.0); // the bed presses on the floor
    return std::tuple{e.particles(), e.energy().friction, box.reaction_x, box.reaction_z};
  };
  const auto [p2a, f2a, rx2a, rz2a] = run(2);
  const auto [p2b, f2b, rx2b, rz2b] = run(2);
  expect_same_particles(p2a, p2b);
  EXPECT_EQ(f2a, f2b);
  EXPECT_EQ(rx2a, rx2b);
  EXPECT_EQ(rz2a, rz2b);
  const auto [p1, f1, rx1, rz1] = run(1);
  EXPECT_NEAR(rx1, rx2a, 1e-6 * std::abs(rz1));
  EXPECT_NEAR(rz1, rz2a, 1e-6 * std::abs(rz1));
  ASSERT_EQ(p1.size(), p2a.size());
  double dmax = 0.0;
  for (std::size_t i = 0; i < p1.size(); ++i) {
    ASSERT_EQ(p1.id[i], p2a.id[i]);
    dmax = std::max({dmax, std::abs(p1.x[i] - p2a.x[i]), std::abs(p1.z[i] - p2a.z[i])});
  }
  EXPECT_LT(dmax, 1e-9); // round-off of a different summation order, not a different model
  EXPECT_NEAR(f1, f2a, 1e-9 * std::max(1.0, std::abs(f1)));
}

// A structure's soil force is summed per part (each part over its particles' contacts) and the
// parts added in part order: a fixed lid just above a shaken lattice, hit by the rising disks,
// gets the same impulse in two runs at 2 threads and, to round-off, at 1 thread.
TEST(DemThreads, StructureForceAddsUpOverParts) {
  auto run = [](int threads) {
    dem::EngineConfig c;
    c.law = dem::contact::make_law("cundall-rebound", {{"kn", 1e7}, {"ks", 3e6}});
    c.threads = threads;
    c.parallel_min_particles = 0;
    dem::Engine e(c);
    add_shaken_lattice(e, 2000, 50, 3); // top row: centres at z = 5.97 m, r ≤ 0.075 m
    add_lid(e, 0.5, 7.0, 6.06, 6.3);
    double impulse_z = 0.0, moment = 0.0;
    for (int s = 0; s < 600; ++s) {
      e.step();
      impulse_z += e.structures()[0].soil_fz * e.dt();
      moment += std::abs(e.structures()[0].soil_moment) * e.dt();
    }
    EXPECT_FALSE(e.failed()) << e.failure();
    EXPECT_EQ(e.threads_in_use(), threads);
    return std::pair{impulse_z, moment};
  };
  const auto [i2a, m2a] = run(2);
  const auto [i2b, m2b] = run(2);
  const auto [i1, m1] = run(1);
  EXPECT_GT(i1, 1.0); // the disks push the lid up: N·s
  EXPECT_GT(m1, 0.1);
  EXPECT_EQ(i2a, i2b);
  EXPECT_EQ(m2a, m2b);
  EXPECT_NEAR(i2a, i1, 1e-6 * i1);
  EXPECT_NEAR(m2a, m1, 1e-6 * m1);
}

// The adaptive team: the work is cut into `threads` parts whatever the number of threads that run
// them, so a team that changes size during the run (1 … threads, as the tuner does on a busy
// machine) gives results bit-identical to the full team.
namespace {
// (out of line: GCC 12 warns falsely about EngineConfig's materials list when inlined here)
[[gnu::noinline]] dem::EngineConfig team_test_config(int threads) {
  dem::EngineConfig c;
  c.law = dem::contact::make_law("cundall-rebound", {{"kn", 1e7}, {"ks", 3e6}});
  c.damping_c = 2.0;
  c.threads = threads;
  c.parallel_min_particles = 0;
  return c;
}

// The adaptive team's clock, faked (set_team_clock): each reading first advances `t` [s] by
// cost(step, team size) for every step taken since the last reading. A test may add to `t` itself
// (time spent outside the engine).
// The team's clock at t: each step adds cost(step, team size), each neighbour rebuild
// rebuild_cost (both at the clock's first reading after them).
void set_fake_team_clock(dem::Engine& e, double& t, std::function<double(long long, int)> cost,
                         double rebuild_cost = 0.0) {
  using clock = std::chrono::steady_clock;
  e.set_team_clock(
      [&e, &t, counted = 0LL, rebuilds = 0LL, rebuild_cost, cost = std::move(cost)]() mutable {
        const long long s = e.stats().steps;
        t += static_cast<double>(s - counted) * cost(s, e.team_size());
        counted = s;
        t += static_cast<double>(e.stats().neighbour_rebuilds - rebuilds) * rebuild_cost;
        rebuilds = e.stats().neighbour_rebuilds;
        return clock::time_point{} +
               std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(t));
      });
}
} // namespace

// Engine::prepare builds the first neighbour list (for 5,000 disks, after the sort into cell
// order) before the first step, as LAMMPS's setup does before its timed loop: the steps after it
// have the same bits and the same rebuilds as without it, on 1 and 2 threads, and a second call
// builds nothing.
TEST(DemEngine, PrepareBuildsTheFirstListWithTheSameBits) {
  for (const int threads : {1, 2}) {
    auto run = [&](bool prepare) {
      dem::Engine e(team_test_config(threads));
      add_shaken_lattice(e, 5000, 100, 3);
      if (prepare) {
        e.prepare();
        EXPECT_EQ(e.stats().neighbour_rebuilds, 1);
        EXPECT_EQ(e.stats().reorders, 1);
        e.prepare();
        EXPECT_EQ(e.stats().neighbour_rebuilds, 1);
        EXPECT_EQ(e.stats().steps, 0);
      }
      e.run_steps(200);
      EXPECT_FALSE(e.failed()) << e.failure();
      return std::tuple{e.particles(), e.stats().neighbour_rebuilds, e.energy().friction};
    };
    const auto [pa, ra, fa] = run(false);
    const auto [pb, rb, fb] = run(true);
    SCOPED_TRACE(threads);
    expect_same_particles(pa, pb);
    EXPECT_EQ(ra, rb);
    EXPECT_GT(ra, 1); // rebuilds during the run too
    EXPECT_EQ(fa, fb);
  }
}

TEST(DemThreads, TeamSizeDoesNotChangeResults) {
  auto run = [](int threads, bool vary) {
    dem::Engine e(team_test_config(threads));
    add_shaken_lattice(e, 1000, 40, 7);
    if (!vary) e.set_team(0);
    for (int s = 0; s < 300; ++s) {
      if (vary) e.set_team(1 + (s / 7) % threads); // 1, 2, …, threads, 1, … every 7 steps
      e.step();
    }
    EXPECT_FALSE(e.failed()) << e.failure();
    EXPECT_GT(e.stats().neighbour_rebuilds, 3); // the rebuild ran with several team sizes too
    if (vary) {
      EXPECT_GT(e.stats().team_one_steps, 0);
      EXPECT_GT(e.stats().team_full_steps, 0);
    }
    return std::pair{e.particles(), e.energy().friction};
  };
  for (const int threads : {2, 3}) {
    const auto [pf, ff] = run(threads, false);
    const auto [pv, fv] = run(threads, true);
    expect_same_particles(pf, pv);
    EXPECT_EQ(ff, fv);
  }
}

// The adaptive team on a fake clock (set_team_clock): a step costs 1 ms on one thread and 0.6 ms
// on the full team, so the full team wins its probes and they grow rarer (every 4, 8, … up to 64
// windows); at step kBusy the other core becomes busy and a full-team step costs 1.5 ms. The
// first slower window tries one thread at once, which wins: the team switches within a few
// windows, not at the next scheduled probe.
TEST(DemThreads, AFullTeamThatSlowsDownTriesOneThreadAtOnce) {
  constexpr long long kBusy = 30000;
  dem::Engine e(team_test_config(2));
  add_shaken_lattice(e, 200, 20, 9);
  double t = 0.0;
  set_fake_team_clock(e, t, [](long long s, int team) {
    return team == 1 ? 1.0e-3 : (s < kBusy ? 0.6e-3 : 1.5e-3);
  });
  e.set_idle_source({}, [] { return 1; }); // the other CPU free at the start: the full team
  e.run_steps(kBusy);
  ASSERT_FALSE(e.failed()) << e.failure();
  const auto before = e.stats();
  EXPECT_EQ(before.team_switches, 0);
  EXPECT_GT(before.team_full_steps, 0.95 * kBusy); // a few probe steps on one thread
  long long steps = 0;
  while (e.stats().team_switches == before.team_switches && steps < 20000) {
    e.run_steps(16);
    steps += 16;
  }
  EXPECT_EQ(e.stats().team_switches, before.team_switches + 1);
  // 240 steps here; 2,032 when only the scheduled probes may switch
  EXPECT_LT(steps, 1000) << "the full team ran on at the busy pace";
  EXPECT_EQ(e.team_size(), 1);
}

// The caller's time between run_until calls (a snapshot, 60 ms here, every 100 steps) is not the
// team's: on a fake clock where the full team is the faster (0.6 ms a step against 1 ms), the
// full team keeps nearly every step. (When the windows counted that time, a window spanning a
// snapshot read as a slow team and probes of one thread won: 10⁵ disks with a snapshot every
// 119 steps ran 35–38 % of their steps on one thread.)
TEST(DemThreads, TheCallersTimeBetweenRunsIsNotTheTeams) {
  dem::Engine e(team_test_config(2));
  add_shaken_lattice(e, 200, 20, 9);
  double t = 0.0;
  set_fake_team_clock(e, t, [](long long, int team) { return team == 1 ? 1.0e-3 : 0.6e-3; });
  e.set_idle_source({}, [] { return 1; }); // the other CPU free at the start: the full team
  constexpr int kRuns = 200;
  for (int r = 0; r < kRuns; ++r) {
    e.run_until(std::numeric_limits<double>::infinity(), 100);
    t += 0.06; // the caller writes a snapshot
  }
  ASSERT_FALSE(e.failed()) << e.failure();
  const auto st = e.stats();
  EXPECT_EQ(st.steps, 100 * kRuns);
  EXPECT_EQ(st.team_switches, 0);
  EXPECT_GT(st.team_full_steps, 0.95 * static_cast<double>(st.steps)) << st.team_one_steps;
}

// A window's pace leaves out the neighbour rebuilds in it. Fake clock: a step costs 0.6 ms on
// the full team and 1 ms on one thread, a rebuild 0.2 s on either. When the rebuilds counted, a
// window holding one read as 2–3× slower, the probe of one thread that followed "won", and the
// team switched to one thread (10⁶ disks: 20 of 200 steps on one thread, 8 % of the loop).
TEST(DemThreads, ARebuildDoesNotMakeTheFullTeamLookSlow) {
  dem::Engine e(team_test_config(2));
  add_shaken_lattice(e, 200, 20, 9);
  double t = 0.0;
  set_fake_team_clock(
      e, t, [](long long, int team) { return team == 1 ? 1.0e-3 : 0.6e-3; }, 0.2);
  e.set_idle_source({}, [] { return 1; }); // the other CPU free at the start: the full team
  e.run_steps(20000);
  ASSERT_FALSE(e.failed()) << e.failure();
  const auto st = e.stats();
  EXPECT_GT(st.neighbour_rebuilds, 20); // many windows hold a rebuild
  EXPECT_EQ(st.team_switches, 0);
  EXPECT_GT(st.team_full_steps, 0.98 * static_cast<double>(st.steps)) << st.team_one_steps;
}

// run_until and run_steps run many steps in one parallel region (Engine::team_steps: a spin
// barrier, no fork and join per step) with the same operations in the same order as step(): the
// same bits. With rebound impulses (V_0 = 0.3 m/s under the lattice's ±1 m/s: the steps with
// events take their serial path inside the region), a fixed lid (the structure sums and
// update_structures), base shaking (the body force read each step) and rebuilds, which end a
// region; chunks of 1 to 37 steps.
TEST(DemThreads, ManyStepsInOneRegionGiveTheStepsBits) {
  struct Result {
    dem::Particles p;
    dem::EnergyBudget energy;
    double lid_fx = 0.0, lid_fz = 0.0, lid_moment = 0.0, time = 0.0;
    dem::EngineStats stats;
  };
  constexpr int kSteps = 400;
  auto run = [](int threads, bool regions) {
    auto c = team_test_config(threads);
    c.law = dem::contact::make_law("cundall-rebound",
                                   {{"kn", 1e7}, {"ks", 3e6}, {"rebound_speed", 0.3}});
    c.shaking = true;
    c.shaking_acceleration = scene::TimeFunction::sine(3.0, 7.0);
    dem::Engine e(c);
    add_shaken_lattice(e, 1000, 40, 11); // top row: centres at z = 3.70 m, r ≤ 0.075 m
    add_lid(e, 0.5, 5.0, 3.79, 4.0);
    e.set_team(threads); // the full team, fixed
    if (regions) {
      for (int s = 0, k = 1; s < kSteps; k = k % 37 + 1) {
        const auto m = static_cast<int>(
            e.run_until(std::numeric_limits<double>::infinity(), std::min(k, kSteps - s)));
        EXPECT_EQ(m, std::min(k, kSteps - s));
        s += m;
      }
    } else {
      for (int s = 0; s < kSteps; ++s) e.step();
    }
    EXPECT_FALSE(e.failed()) << e.failure();
    const auto& st = e.structures()[0];
    return Result{e.particles(),  e.energy(), st.soil_fx, st.soil_fz,
                  st.soil_moment, e.time(),   e.stats()};
  };
  for (const int threads : {2, 3}) {
    const Result a = run(threads, false), b = run(threads, true);
    EXPECT_EQ(a.stats.team_region_steps, 0);
    EXPECT_GT(b.stats.team_region_steps, kSteps / 2) << "the steps did not run in regions";
    EXPECT_GT(a.stats.neighbour_rebuilds, 3);
    EXPECT_GT(a.stats.rebound_contacts, 50);
    EXPECT_GT(std::abs(a.lid_fz), 0.0); // the disks reach the lid
    expect_same_particles(a.p, b.p);
    EXPECT_EQ(a.stats.steps, b.stats.steps);
    EXPECT_EQ(a.stats.neighbour_rebuilds, b.stats.neighbour_rebuilds);
    EXPECT_EQ(a.stats.rebound_contacts, b.stats.rebound_contacts);
    EXPECT_EQ(a.time, b.time);
    EXPECT_EQ(a.energy.friction, b.energy.friction);
    EXPECT_EQ(a.energy.damping, b.energy.damping);
    EXPECT_EQ(a.energy.rebound, b.energy.rebound);
    EXPECT_EQ(a.energy.external_work, b.energy.external_work);
    EXPECT_EQ(a.energy.spring_normal, b.energy.spring_normal);
    EXPECT_EQ(a.lid_fx, b.lid_fx);
    EXPECT_EQ(a.lid_fz, b.lid_fz);
    EXPECT_EQ(a.lid_moment, b.lid_moment);
  }
}

// run_until stops at the first step whose time reaches t_stop − Δt/2 (a runner's probe test),
// whether the steps run in regions (2 threads) or one by one (1 thread), and at max_steps.
TEST(DemThreads, RunUntilStopsWhereARunnerLoopWould) {
  for (const int threads : {1, 2}) {
    dem::Engine e(team_test_config(threads));
    add_shaken_lattice(e, 600, 30, 5);
    e.set_team(threads);
    const double dt = e.dt();
    const double t_stop = 57.3 * dt;
    const long long m = e.run_until(t_stop, 1000);
    EXPECT_GE(e.time(), t_stop - 0.5 * dt);
    EXPECT_LT(e.time() - dt, t_stop - 0.5 * dt);
    EXPECT_EQ(m, e.stats().steps);
    EXPECT_EQ(e.run_until(t_stop, 1000), 0); // already there
    EXPECT_EQ(e.run_until(1.0, 13), 13);
    EXPECT_EQ(e.stats().steps, m + 13);
    if (threads > 1) {
      EXPECT_GT(e.stats().team_region_steps, 0);
    }
  }
}

// The adaptive team reads how idle the other CPUs were before it probes the full team: while they
// are busy it never runs a 2-thread step (each such probe stalls on the busy core: 0.84 of one
// thread at 10⁴ disks with the probes, 1.00 without, bench/RESULTS.md); while they idle it probes.
TEST(DemThreads, TheFullTeamIsProbedOnlyWhenAnotherCpuIdles) {
  using clock = std::chrono::steady_clock;
  auto run = [](std::function<double()> idle) {
    dem::Engine e(team_test_config(2));
    add_shaken_lattice(e, 1000, 40, 7);
    if (idle) e.set_idle_source(std::move(idle));
    // Decisions are made on windows of ≥ 0.05 s of steps: run until a few were made (≤ 5 s).
    const auto t0 = clock::now();
    while (clock::now() - t0 < std::chrono::seconds(5) && !e.failed() &&
           e.stats().team_full_steps == 0 && e.stats().team_probes_skipped < 3)
      e.run_steps(20);
    EXPECT_FALSE(e.failed()) << e.failure();
    return e.stats();
  };
  const auto t_start = clock::now();
  auto cpu_seconds_since_start = [t_start](double cpus) {
    return [t_start, cpus] {
      return cpus * std::chrono::duration<double>(clock::now() - t_start).count();
    };
  };
  // The other CPU busy: its idle counter does not move (one idle CPU-second over the whole run,
  // as a real counter gives under `stress-ng --cpu 1`).
  const auto busy = run([] { return 1.0; });
  EXPECT_EQ(busy.team_full_steps, 0);
  EXPECT_GE(busy.team_probes_skipped, 3);
  // One CPU idle all the time (the counter grows by 1 CPU-second per second): probed.
  const auto idle = run(cpu_seconds_since_start(1.0));
  EXPECT_GT(idle.team_full_steps, 0);
  EXPECT_EQ(idle.team_probes_skipped, 0);
  // A quarter of a CPU idle: below the half the second thread needs, not probed.
  const auto quarter = run(cpu_seconds_since_start(0.25));
  EXPECT_EQ(quarter.team_full_steps, 0);
  // No reading (NaN, or no source): every probe is made, as before the reading existed.
  const auto unknown = run([] { return std::numeric_limits<double>::quiet_NaN(); });
  EXPECT_GT(unknown.team_full_steps, 0);
  EXPECT_GT(run({}).team_full_steps, 0);
}

// The first choice: with the full team's CPUs free at the first step (set_idle_source's second
// reading) the run starts on the full team; else on one thread, as before that reading existed.
// The race's 10⁴ disks had spent their first 132 of 2,000 steps on one thread on an idle machine.
TEST(DemThreads, StartsOnTheFullTeamWhenItsCpusAreFreeNow) {
  auto first_steps = [](std::function<int()> free_now) {
    dem::Engine e(team_test_config(2));
    add_shaken_lattice(e, 1000, 40, 7);
    e.set_idle_source([] { return std::numeric_limits<double>::quiet_NaN(); }, std::move(free_now));
    e.run_steps(4); // within the first window: no probe yet
    EXPECT_FALSE(e.failed()) << e.failure();
    return std::pair{e.stats().team_full_steps, e.stats().team_one_steps};
  };
  EXPECT_EQ(first_steps([] { return 1; }), (std::pair{4LL, 0LL})); // one CPU free besides ours
  EXPECT_EQ(first_steps([] { return 3; }), (std::pair{4LL, 0LL}));
  EXPECT_EQ(first_steps([] { return 0; }), (std::pair{0LL, 4LL}));  // the other CPU busy
  EXPECT_EQ(first_steps([] { return -1; }), (std::pair{0LL, 4LL})); // unknown
  EXPECT_EQ(first_steps({}), (std::pair{0LL, 4LL}));
  // This machine: a count, or −1 where /proc cannot be read.
  EXPECT_GE(dem::free_cpus_now(), -1);
}

// /proc/stat's procs_running and a task's state in /proc/<pid>/task/<tid>/stat.
TEST(CpuIdle, ReadsRunnableTasks) {
  EXPECT_EQ(dem::procs_running_from_proc_stat("cpu  1 2 3 4\nctxt 9\nprocs_running 3\n"
                                              "procs_blocked 0\n"),
            3);
  EXPECT_EQ(dem::procs_running_from_proc_stat("procs_running 12"), 12);
  EXPECT_EQ(dem::procs_running_from_proc_stat("cpu  1 2 3 4\nprocs_blocked 0\n"), -1);
  EXPECT_EQ(dem::procs_running_from_proc_stat("procs_running x\n"), -1);
  EXPECT_TRUE(dem::task_stat_is_running("4711 (demfem) R 1 4711 4711 0 -1"));
  EXPECT_FALSE(dem::task_stat_is_running("4711 (demfem) S 1 4711 4711 0 -1"));
  EXPECT_TRUE(dem::task_stat_is_running("9 (a) b) S) R 1 2")); // ')' and states in the name
  EXPECT_FALSE(dem::task_stat_is_running("9 (x"));
  EXPECT_FALSE(dem::task_stat_is_running(""));
  const int others = dem::other_runnable_tasks();
  EXPECT_GE(others, -1);
}

// /proc/stat: the idle and iowait columns of the per-CPU lines in the affinity mask, in seconds.
TEST(CpuIdle, ReadsIdleAndIowaitOfTheAllowedCpus) {
  const std::string text = "cpu  400 0 200 9000 100 0 0 0 0 0\n"
                           "cpu0 200 0 100 4000 50 0 0 0 0 0\n"
                           "cpu1 200 0 100 5000 50 0 0 0 0 0\n"
                           "intr 12345 0 0\n"
                           "ctxt 999\n";
  EXPECT_DOUBLE_EQ(dem::idle_seconds_from_proc_stat(text, {}, 100.0), 91.0);
  EXPECT_DOUBLE_EQ(dem::idle_seconds_from_proc_stat(text, {false, true}, 100.0), 50.5);
  EXPECT_DOUBLE_EQ(dem::idle_seconds_from_proc_stat(text, {true}, 100.0), 40.5); // cpu1 not allowed
  EXPECT_DOUBLE_EQ(dem::idle_seconds_from_proc_stat("cpu3 1 2 3 4\n", {}, 1.0), 4.0); // no iowait
  EXPECT_TRUE(std::isnan(dem::idle_seconds_from_proc_stat("cpu  1 2 3 4 5\n", {}, 100.0)));
  EXPECT_TRUE(std::isnan(dem::idle_seconds_from_proc_stat("", {}, 100.0)));
  // This machine: a counter that does not run backwards.
  const double a = dem::idle_cpu_seconds();
  const double b = dem::idle_cpu_seconds();
  if (!std::isnan(a)) {
    EXPECT_GE(b, a);
  }
}

// A packing stores its particle–particle contact history; the cache returns the same blob and a
// run that starts from the packing starts with its shear springs.
TEST(DemResume, PackingKeepsContactHistory) {
  auto f = scene::load_scene_file(DEMFEM_SOURCE_DIR "/cases/retaining_wall.toml",
                                  demfem::app::vocabulary());
  auto s = f.base;
  s.soil.dem->packing.cache.clear();
  s.soil.dem->count = 200;
  const auto dir = scratch("pack");
  const auto a = dem::pack_or_load(s, dir);
  ASSERT_FALSE(a.from_cache);
  ASSERT_FALSE(a.contact_history.empty());
  const auto b = dem::pack_or_load(s, dir);
  ASSERT_TRUE(b.from_cache);
  EXPECT_EQ(a.contact_history, b.contact_history);
  EXPECT_EQ(a.particles.x, b.particles.x);
  // Shear force carried into the first step with and without the history.
  auto first_step_shear = [&](bool with_history) {
    dem::Engine e(dem::make_config(s));
    for (std::size_t i = 0; i < b.particles.size(); ++i)
      e.add_particle(b.particles.x[i], b.particles.z[i], b.particles.radius[i]);
    if (with_history) e.load_contact_history(b.contact_history);
    for (const auto& w : s.walls) e.add_wall(w);
    e.set_dt(e.auto_dt());
    e.step();
    std::vector<dem::ContactView> cv;
    e.contacts(cv);
    double sum = 0.0;
    for (const auto& c : cv)
      if (c.j >= 0) sum += std::abs(c.fs);
    return sum;
  };
  const double with = first_step_shear(true), without = first_step_shear(false);
  EXPECT_GT(with, 10.0 * without) << with << " vs " << without;
}

// A packing cache that cannot be read (here: cut short) is deposited again, and the log says so:
// the rebuild (minutes on a large bed) is never silent.
TEST(DemResume, CorruptPackingCacheIsRebuiltWithALogLine) {
  auto f = scene::load_scene_file(DEMFEM_SOURCE_DIR "/cases/retaining_wall.toml",
                                  demfem::app::vocabulary());
  auto s = f.base;
  s.soil.dem->packing.cache.clear();
  s.soil.dem->count = 150;
  const auto dir = scratch("pack-corrupt");
  const auto a = dem::pack_or_load(s, dir);
  ASSERT_FALSE(a.from_cache);
  const auto size = std::filesystem::file_size(a.path);
  std::filesystem::resize_file(a.path, size / 2);
  std::ostringstream log;
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(log);
  spdlog::default_logger()->sinks().push_back(sink);
  const auto b = dem::pack_or_load(s, dir);
  spdlog::default_logger()->sinks().pop_back();
  EXPECT_FALSE(b.from_cache);
  EXPECT_EQ(a.particles.x, b.particles.x); // deposited again, the same bed
  EXPECT_NE(log.str().find("cannot be read"), std::string::npos) << log.str();
  EXPECT_NE(log.str().find(a.path.string()), std::string::npos) << log.str();
  EXPECT_GT(std::filesystem::file_size(b.path), size / 2); // replaced whole
}

// The blocked, vectorised pair loop of cundall-rebound (pair_kernel.hpp) computes what the one-pass
// scalar loop computes, bit for bit: every particle array and every energy, on (a) a shaken bed
// of two materials with rebounds (first touches, releases and the touch/release spring steps go
// through the scalar law inside the blocked loop), at 1 and 2 threads, and (b) a large disk with
// more partners in its list than a block holds (an owner split across blocks).
namespace {
using Kernel = dem::EngineConfig::PairKernel;

[[gnu::noinline]] dem::EngineConfig kernel_test_config(Kernel k, int threads) {
  dem::EngineConfig c = team_test_config(threads);
  c.pair_kernel = k;
  return c;
}

struct KernelRun {
  dem::Particles p;
  dem::EnergyBudget en;
  std::size_t contacts_of_first = 0;
};

KernelRun shaken_two_materials(Kernel k, int threads) {
  dem::Engine e(kernel_test_config(k, threads));
  add_shaken_lattice(e, 1000, 40, 11);
  EXPECT_GT(e.set_friction({{0, 0}, {3, 0}, {3, 5}, {0, 5}}, 0.3, 0.1), 400u); // half the bed
  e.run_steps(400);
  EXPECT_FALSE(e.failed()) << e.failure();
  return {e.particles(), e.energy(), 0};
}

// One disk of radius 1 m and a ring of 180 disks of radius 0.017 m, 2 mm away, moving onto it at
// 0.6 m/s: every ring disk is a partner in the large disk's list (it is added first and never
// reordered).
KernelRun ring_on_large_disk(Kernel k) {
  dem::EngineConfig c = kernel_test_config(k, 1);
  c.gravity = 0.0;
  c.reorder_every = 0;
  c.law = dem::contact::make_law("cundall-rebound", // the impacts at 0.6 m/s rebound
                                 {{"kn", 1e7}, {"ks", 3e6}, {"rebound_speed", 0.5}});
  dem::Engine e(c);
  e.add_particle(0.0, 0.0, 1.0);
  const int n = 180;
  for (int q = 0; q < n; ++q) {
    const double a = 2.0 * 3.14159265358979323846 * q / n;
    e.add_particle(1.019 * std::cos(a), 1.019 * std::sin(a), 0.017, -0.6 * std::cos(a),
                   -0.6 * std::sin(a));
  }
  e.set_dt(e.auto_dt());
  KernelRun r;
  std::vector<dem::ContactView> cv;
  for (int s = 0; s < 20; ++s) { // the most contacts of the large disk at any 50th step
    e.run_steps(50);
    e.contacts(cv);
    std::size_t touching = 0;
    for (const auto& v : cv) touching += (v.i == 0 || v.j == 0) ? 1u : 0u;
    r.contacts_of_first = std::max(r.contacts_of_first, touching);
  }
  EXPECT_FALSE(e.failed()) << e.failure();
  r.p = e.particles();
  r.en = e.energy();
  return r;
}

void expect_same_energy(const dem::EnergyBudget& a, const dem::EnergyBudget& b) {
  EXPECT_EQ(a.friction, b.friction);
  EXPECT_EQ(a.rebound, b.rebound);
  EXPECT_EQ(a.damping, b.damping);
  EXPECT_EQ(a.spring_normal, b.spring_normal);
  EXPECT_EQ(a.spring_shear, b.spring_shear);
  EXPECT_EQ(a.kinetic, b.kinetic);
}
} // namespace

TEST(DemPairKernel, BlockedLoopBitIdenticalToScalar) {
  for (const int threads : {1, 2}) {
    const auto ref = shaken_two_materials(Kernel::scalar, threads);
    EXPECT_GT(ref.en.rebound, 1.0);  // rebounds: the scalar law ran inside the blocked loop
    EXPECT_GT(ref.en.friction, 0.0); // sliding contacts
    for (const Kernel k : {Kernel::portable, Kernel::avx2, Kernel::simd}) {
      SCOPED_TRACE(::testing::Message() << "threads " << threads << ", kernel " << int(k));
      const auto r = shaken_two_materials(k, threads);
      expect_same_particles(ref.p, r.p);
      expect_same_energy(ref.en, r.en);
    }
  }
  const auto ref = ring_on_large_disk(Kernel::scalar);
  EXPECT_GT(ref.contacts_of_first, 128u); // more than one block (PairBlock::kSize)
  EXPECT_GT(ref.en.rebound, 0.0);
  for (const Kernel k : {Kernel::portable, Kernel::avx2, Kernel::simd}) {
    const auto r = ring_on_large_disk(k);
    EXPECT_EQ(r.contacts_of_first, ref.contacts_of_first);
    expect_same_particles(ref.p, r.p);
    expect_same_energy(ref.en, r.en);
  }
}

// Friction of the pairs (engine: update_pair_friction): when every material in use has the same
// μ_s, μ_d the pair loops take them as constants. A bed whose friction is set to (0.3, 0.1) for
// every particle by an event (two materials, the soil's no longer in use) runs bit-identically to
// a bed built with (0.3, 0.1) as its only material, for the blocked and the one-pass loop; a
// half-bed event (two frictions in use) differs from both.
TEST(DemPairKernel, UniformFrictionOfAnEventEqualsOneMaterial) {
  for (const Kernel k : {Kernel::scalar, Kernel::avx2, Kernel::simd}) {
    SCOPED_TRACE(::testing::Message() << "kernel " << int(k));
    auto run = [k](int mode) { // 0: one material; 1: event on the whole bed; 2: half the bed
      dem::EngineConfig c = kernel_test_config(k, 1);
      if (mode == 0) c.materials = {dem::Material{0.3, 0.1}};
      dem::Engine e(c);
      add_shaken_lattice(e, 1000, 40, 11);
      if (mode == 1) {
        EXPECT_EQ(e.set_friction({{-1, -1}, {9, -1}, {9, 9}, {-1, 9}}, 0.3, 0.1), 1000u);
      } else if (mode == 2) {
        EXPECT_GT(e.set_friction({{0, 0}, {3, 0}, {3, 5}, {0, 5}}, 0.3, 0.1), 400u);
      }
      e.run_steps(300);
      EXPECT_FALSE(e.failed()) << e.failure();
      return KernelRun{e.particles(), e.energy(), 0};
    };
    const auto one = run(0), half = run(2);
    auto all = run(1);
    EXPECT_GT(one.en.friction, 0.0);
    for (const auto m : all.p.material) ASSERT_EQ(m, 1u); // the event's material
    std::fill(all.p.material.begin(), all.p.material.end(), std::uint16_t{0});
    expect_same_particles(one.p, all.p);
    expect_same_energy(one.en, all.en);
    EXPECT_NE(one.en.friction, half.en.friction);
  }
}

// The kernel's division-free "closed contact stays closed" test (contact::detail::stays_closed) is
// true only where linear_spring_force's arithmetic has d_prev ≥ 0 and d_next ≥ 0 (else the kernel
// would apply K_n δ where the law applies its release root): scanned over the few thousand
// doubles of v_n around d_next = 0 for several masses, steps and overlaps, and it still says
// "closed" a relative 1e-9 inside.
TEST(DemPairKernel, StaysClosedTestImpliesTheLaws) {
  const double kn = 1.0e6;
  std::size_t open = 0, left_to_the_law = 0;
  for (const double mi : {1.3, 0.02, 7.0e3})
    for (const double mj : {0.7, 0.02, 2.0e5})
      for (const double dt : {1.0e-3, 8.4e-5})
        for (const double delta : {1.5e-4, 3.0e-6}) {
          const double fc = kn * delta, dt2 = dt * dt;
          const double meff = mi * mj / (mi + mj); // as linear_spring_force computes them
          const double A = dt * dt / meff;
          const double vn0 = (fc * A - delta) / dt; // d_next = 0
          if (!(delta - vn0 * dt >= 0.0)) continue; // d_prev < 0: the touch step, not this case
          double vn = vn0;
          for (int k = 0; k < 3000; ++k) vn = std::nextafter(vn, -1e300);
          for (int k = 0; k < 6000; ++k, vn = std::nextafter(vn, 1e300)) {
            const double d_prev = delta - vn * dt;
            const double d_next = delta + vn * dt - fc * A;
            const bool law = d_prev >= 0.0 && d_next >= 0.0;
            const bool kernel = dem::contact::detail::stays_closed(delta, vn, dt, dt2, fc, mi, mj);
            ASSERT_TRUE(!kernel || law) << "m " << mi << ", " << mj << " dt " << dt << " delta "
                                        << delta << " vn " << vn << ": d_next " << d_next;
            open += law ? 0u : 1u;
            left_to_the_law += (law && !kernel) ? 1u : 0u;
          }
          const double vn_in = vn0 + 1e-9 * std::abs(fc * A) / dt; // clearly closed
          EXPECT_TRUE(dem::contact::detail::stays_closed(delta, vn_in, dt, dt2, fc, mi, mj));
        }
  EXPECT_GT(open, 0u);            // the scan crosses the law's d_next = 0
  EXPECT_GT(left_to_the_law, 0u); // and the kernel's margin
}

// The probes' cheap forms (run/probe_source.cpp): pair_contact_count, the boundary
// contacts alone, and largest_overlap_ratio give what the full contact list gives.
TEST(DemContacts, ProbeFormsAgreeWithTheContactList) {
  dem::EngineConfig c;
  c.law = dem::contact::make_law("cundall-rebound", {{"kn", 1e7}, {"ks", 3e6}});
  c.damping_c = 2.0;
  dem::Engine e(c);
  add_shaken_lattice(e, 1000, 40, 5);
  e.run_steps(4000); // the lattice collapses onto the floor
  ASSERT_FALSE(e.failed()) << e.failure();
  std::vector<dem::ContactView> all, walls;
  e.contacts(all);
  e.contacts(walls, false);
  std::size_t pairs = 0;
  double worst = 0.0;
  const auto& p = e.particles();
  for (const auto& v : all) {
    const double ri = p.radius[v.i];
    if (v.j >= 0) {
      ++pairs;
      const auto j = static_cast<std::size_t>(v.j);
      const double dx = p.x[v.i] - p.x[j], dz = p.z[v.i] - p.z[j];
      const double d = std::sqrt(dx * dx + dz * dz);
      worst = std::max(worst, (ri + p.radius[j] - d) / std::min(ri, p.radius[j]));
    } else if (v.fn > 0.0) {
      worst = std::max(worst, v.fn / 1e7 / ri); // δ = f_n / K_n
    }
  }
  EXPECT_GT(pairs, 300u);
  EXPECT_EQ(e.pair_contact_count(), pairs);
  ASSERT_EQ(walls.size(), all.size() - pairs);
  EXPECT_GT(walls.size(), 10u); // the bed rests on the box
  for (std::size_t k = 0; k < walls.size(); ++k) {
    EXPECT_EQ(walls[k].i, all[pairs + k].i);
    EXPECT_EQ(walls[k].fn, all[pairs + k].fn);
  }
  EXPECT_GT(worst, 0.0);
  EXPECT_EQ(e.largest_overlap_ratio(), worst); // the maximum, not an estimate
  // Overlapping pairs at the current positions: every pair of particles, counted directly. The
  // neighbour list's skin must hold them all, touching at the last force evaluation or not.
  std::size_t overlapping = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      const double dx = p.x[i] - p.x[j], dz = p.z[i] - p.z[j], rs = p.radius[i] + p.radius[j];
      overlapping += dx * dx + dz * dz <= rs * rs ? 1u : 0u;
    }
  EXPECT_GT(overlapping, 300u);
  EXPECT_EQ(e.overlapping_pair_count(), overlapping);
}

// The integration (integrate_kernel.hpp) is the same bits with every instruction set: positions,
// velocities and the energy sums (external work of the shaking, damping loss: 8 fixed lanes)
// of a shaken, damped bed of 1,003 disks (not a multiple of 8: the tail), at 1 and 2 threads,
// with one disk dropped under the box (removed at a rebuild: its part takes the scalar path).
TEST(DemIntegrate, SameBitsWithEveryInstructionSet) {
  for (const int threads : {1, 2}) {
    auto run = [threads](Kernel k) {
      dem::EngineConfig c = kernel_test_config(k, threads);
      c.damping_d = 0.5;
      c.shaking = true;
      c.shaking_direction = 'x';
      c.shaking_acceleration = scene::TimeFunction::sine(3.0, 5.0);
      dem::Engine e(c);
      add_shaken_lattice(e, 1002, 40, 13);
      e.add_particle(1.0, -3.0, 0.05); // below the floor: falls out of the scene
      e.set_dt(e.auto_dt());
      e.run_steps(1500);
      EXPECT_FALSE(e.failed()) << e.failure();
      return std::tuple{e.particles(), e.energy()};
    };
    const auto [p0, e0] = run(Kernel::portable);
    std::size_t removed = 0;
    for (const auto f : p0.flags) removed += (f & dem::kFlagRemoved) ? 1u : 0u;
    EXPECT_EQ(removed, 1u) << "the dropped disk was not removed";
    EXPECT_GT(std::abs(e0.external_work), 1.0);
    EXPECT_GT(e0.damping, 1.0);
    for (const Kernel k : {Kernel::avx2, Kernel::simd}) {
      SCOPED_TRACE(::testing::Message() << "threads " << threads << ", kernel " << int(k));
      const auto [p, en] = run(k);
      expect_same_particles(p0, p);
      expect_same_energy(e0, en);
      EXPECT_EQ(e0.external_work, en.external_work);
      EXPECT_EQ(e0.left_scene, en.left_scene);
    }
  }
}

// Probes with intervals of their own: their schedules go into the checkpoint (run state version
// 2), and a resumed run equals the straight one.
TEST(DemResume, ProbesWithTheirOwnIntervalsResumeBitForBit) {
  auto scene = [](double duration) {
    auto sc = resume_scene(duration);
    for (auto& p : sc.probes) {
      if (p.kind == scene::ProbeKind::Energy) p.interval = 0.03;
      if (p.kind == scene::ProbeKind::PressureProfile) p.interval = 0.02;
    }
    return sc;
  };
  dem::RunOptions a;
  a.out_dir = scratch("straight4");
  a.threads = 1;
  ASSERT_TRUE(dem::run(scene(0.3), a).ok);
  dem::RunOptions b = a;
  b.out_dir = scratch("split4");
  ASSERT_TRUE(dem::run(scene(0.1537), b).ok);
  b.resume = true;
  const auto s2 = dem::run(scene(0.3), b);
  ASSERT_TRUE(s2.ok) << s2.message;
  expect_same_outputs(a.out_dir, b.out_dir);
}
