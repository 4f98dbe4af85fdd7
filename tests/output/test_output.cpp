// The run-directory contract (output/): the CSV writer and reader, the column contract both
// solvers write, and the probes' schedules.
#include <gtest/gtest.h>

#include "../scratch.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "demfem/output/contract.hpp"
#include "demfem/output/csv.hpp"
#include "demfem/output/probe.hpp"

namespace fs = std::filesystem;
using namespace demfem;
using output::CsvError;
using output::CsvFormat;
using output::CsvOptions;
using output::CsvWriter;

namespace {

std::vector<std::string> lines_of(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

CsvOptions with_comment(const std::string& c) {
  CsvOptions o;
  o.comments = {c};
  return o;
}

} // namespace

TEST(Csv, HeaderAndFullPrecisionRows) {
  const fs::path file = test::scratch("structure.csv");
  {
    CsvWriter w(file, {"time [s]", "force [N]", "moment, about pivot [N·m]"},
                with_comment("demfem 0.1.0"));
    w.append({0.0, 1.0 / 3.0, -2.5e-12});
    // Flushed after every row by default: visible before the writer closes.
    EXPECT_EQ(lines_of(file).size(), 3u);
    w.append({0.1, 123456789.123, 1e300});
    EXPECT_THROW(w.append({1.0, 2.0}), CsvError);
    EXPECT_EQ(w.rows(), 2u);
  }
  const auto lines = lines_of(file);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0], "# demfem 0.1.0");
  EXPECT_EQ(lines[1], "time [s],force [N],\"moment, about pivot [N·m]\"");
  EXPECT_EQ(lines[2], "0,0.333333333,-2.5e-12");
  EXPECT_EQ(lines[3], "0.1,123456789,1e+300");
  EXPECT_THROW(CsvWriter(test::scratch("none.csv"), {}), CsvError);
  EXPECT_THROW(CsvWriter(test::scratch("no_such_dir") / "x.csv", {"t [s]"}), CsvError);
}

// What the writer writes, the reader reads: comments, quoted column names, every value to its
// printed precision, NaN.
TEST(Csv, RoundTrip) {
  const fs::path file = test::scratch("round.csv");
  const std::vector<std::string> cols = {"time [s]", "wall.thrust [N]", "a \"quoted\", name [-]"};
  {
    CsvWriter w(file, cols, with_comment("demfem dem run of x"));
    w.append({0.0, 1.5, std::nan("")});
    w.append({0.01, -2.25e-7, 3.0});
  }
  const auto t = output::read_csv(file);
  ASSERT_EQ(t.comments.size(), 1u);
  EXPECT_EQ(t.comments[0], "demfem dem run of x");
  EXPECT_EQ(t.columns, cols);
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.rows[1][1], -2.25e-7);
  EXPECT_TRUE(std::isnan(t.rows[0][2]));
  EXPECT_EQ(t.find("wall.thrust"), 1); // without its unit
  EXPECT_EQ(t.find("wall.thrust [N]"), 1);
  EXPECT_EQ(t.find("wall.thr"), -1);
  EXPECT_EQ(t.column("time"), (std::vector<double>{0.0, 0.01}));
  EXPECT_TRUE(t.column("missing").empty());
  EXPECT_TRUE(output::read_csv(test::scratch("absent.csv")).columns.empty());
}

TEST(Csv, ColumnFormats) {
  const fs::path file = test::scratch("steps.csv");
  {
    CsvOptions o;
    o.formats = {CsvFormat::integer(), CsvFormat::general(6), CsvFormat::scientific(3),
                 CsvFormat::fixed(4)};
    CsvWriter w(file, {"step", "time [s]", "residual", "wall [s]"}, o);
    w.append({12, 0.123456789, 1.5e-9, 0.25});
  }
  EXPECT_EQ(lines_of(file).at(1), "12,0.123457,1.500e-09,0.2500");
}

TEST(Csv, ResumeKeepsRowsUpToTheCheckpoint) {
  const fs::path file = test::scratch("energy.csv");
  {
    CsvWriter w(file, {"time [s]", "kinetic [J]"}, with_comment("demfem"));
    for (int k = 0; k < 6; ++k) w.append({0.1 * k, 2.0 * k});
  }
  {
    CsvOptions o;
    o.resume_after = 0.25;
    CsvWriter w(file, {"time [s]", "kinetic [J]"}, o);
    EXPECT_EQ(w.rows(), 3u);
    w.append({0.3, 7.0});
  }
  const auto lines = lines_of(file);
  ASSERT_EQ(lines.size(), 6u);
  EXPECT_EQ(lines[0], "# demfem");
  EXPECT_EQ(lines[4], "0.2,4");
  EXPECT_EQ(lines[5], "0.3,7");
  CsvOptions o;
  o.resume_after = 0.25;
  EXPECT_THROW(CsvWriter(file, {"time [s]", "other [J]"}, o), CsvError);
}

// A failed write names the file and the cause: thrown at once, or kept (keep_errors) for the
// caller to raise where every MPI rank stops together; later rows are then dropped.
TEST(Csv, FailedWritesAreReported) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  try {
    CsvWriter w("/dev/full", {"time [s]"});
    ADD_FAILURE() << "no error";
  } catch (const CsvError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot write /dev/full: No space left on device"),
              std::string::npos)
        << e.what();
  }
  CsvOptions o;
  o.keep_errors = true;
  CsvWriter w("/dev/full", {"time [s]"}, o);
  EXPECT_NE(w.error().find("cannot write /dev/full: No space left on device"), std::string::npos)
      << w.error();
  w.append({1.0}); // dropped
  w.close();
  EXPECT_EQ(w.rows(), 0u);
}

// The column contract: the header cells both solvers write, and the names compare reads.
TEST(Contract, Columns) {
  using namespace output;
  EXPECT_EQ(heading(col::time), "time [s]");
  EXPECT_EQ(heading("wall", col::thrust), "wall.thrust [N]");
  EXPECT_EQ(key("pile", col::settlement), "pile.settlement");
  EXPECT_EQ(heading(col::coordination), "coordination [-]");
  EXPECT_EQ(heading(col::newton_iterations), "newton iterations");
  EXPECT_EQ(bin_heading("wall", 3, col::pressure_bin), "wall.bin3 [Pa]");
  EXPECT_EQ(bin_heading(col::surface_owner, 0, col::surface_bin), "surface.bin0 [m]");
  std::string owner;
  int k = -1;
  EXPECT_TRUE(is_bin_heading("left wall.bin12 [Pa]", &owner, &k));
  EXPECT_EQ(owner, "left wall");
  EXPECT_EQ(k, 12);
  EXPECT_FALSE(is_bin_heading("wall.binary [Pa]"));
  EXPECT_EQ(heading(locus_owner(42), col::locus_x), "p42.x [m]");
  EXPECT_EQ(file::pressure("wall"), "pressure_wall.csv");
  std::vector<std::string> energy;
  for (const auto& c : kEnergyColumns) energy.push_back(heading(c));
  EXPECT_EQ(energy,
            (std::vector<std::string>{"kinetic [J]", "rotational [J]", "potential [J]",
                                      "spring_normal [J]", "spring_shear [J]", "friction [J]",
                                      "damping [J]", "rebound [J]", "external_work [J]",
                                      "gravity_work [J]", "imbalance [J]", "left_scene [J]"}));
  // Every time series a solver writes is listed, with who writes it.
  std::map<std::string, Writer> listed;
  for (const auto& f : run_directory()) listed[std::string(f.name)] = f.writer;
  for (const auto n : {file::energy, file::structures, file::walls, file::surface, file::loci,
                       file::coordination, file::steps, file::surface_profile})
    EXPECT_TRUE(listed.count(std::string(n))) << n;
  EXPECT_EQ(listed.at(std::string(file::structures)), Writer::Both);
  EXPECT_EQ(listed.at(std::string(file::energy)), Writer::Dem);
}

namespace {

// A solver that answers every probe with values that encode the time.
class FakeSource final : public output::ProbeSource {
public:
  double t = 0.0;
  bool particles = true;
  [[nodiscard]] double time() const override { return t; }
  [[nodiscard]] bool has_energy() const override { return particles; }
  [[nodiscard]] bool has_particles() const override { return particles; }
  [[nodiscard]] bool has_boundary(std::string_view name) const override { return name == "wall"; }
  output::EnergyTerms energy() override {
    output::EnergyTerms e;
    e.kinetic = t;
    return e;
  }
  output::StructureState structure(std::size_t k) override {
    output::StructureState s;
    s.settlement = t + static_cast<double>(k);
    return s;
  }
  output::WallReaction wall(std::string_view) override { return {t, 0, 0}; }
  void pressure(std::string_view, std::span<double> b) override {
    for (auto& v : b) v = t;
  }
  void surface(std::span<double> b) override {
    for (auto& v : b) v = t;
  }
  std::vector<std::uint32_t> trace(std::span<const scene::Vec2> points) override {
    std::vector<std::uint32_t> ids;
    for (std::size_t k = 0; k < points.size(); ++k)
      ids.push_back(static_cast<std::uint32_t>(7 + k));
    return ids;
  }
  scene::Vec2 position(std::uint32_t id) override { return {t, static_cast<double>(id)}; }
  double coordination() override { return 3.0; }
};

scene::Scene probe_scene() {
  scene::Scene sc;
  sc.output.probe_interval = 0.01;
  scene::Structure s;
  s.name = "wall";
  s.kind = scene::StructureKind::Wall;
  sc.structures.push_back(s);
  auto add = [&](scene::ProbeKind kind, double interval) -> scene::Probe& {
    scene::Probe p;
    p.kind = kind;
    p.interval = interval;
    sc.probes.push_back(p);
    return sc.probes.back();
  };
  add(scene::ProbeKind::Energy, 0.05);
  add(scene::ProbeKind::Coordination, 0.0);
  add(scene::ProbeKind::SurfaceProfile, 0.02).bins = 3;
  auto& pr = add(scene::ProbeKind::PressureProfile, 0.03);
  pr.target = "wall";
  pr.bins = 2;
  add(scene::ProbeKind::Loci, 0.0).points = {{1, 2}, {3, 4}};
  return sc;
}

// Steps of 0.005 s from 0 to 0.1 s, sampling as the DEM driver does (due within half a step).
void run_steps(output::ProbeSet& set, FakeSource& src, int from, int to) {
  for (int n = from; n <= to; ++n) {
    src.t = 0.005 * n;
    if (set.any_due(src.t, 0.0025)) set.sample_due(src, 0.0025);
  }
}

std::vector<double> times_of(const fs::path& f) {
  return output::read_csv(f).column("time");
}

std::vector<double> expected(double dt, double end) {
  std::vector<double> t;
  for (int k = 0; 0.005 * std::round(k * dt / 0.005) <= end + 1e-12; ++k)
    t.push_back(0.005 * std::round(k * dt / 0.005));
  return t;
}

void expect_times(const std::vector<double>& got, const std::vector<double>& want,
                  const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (std::size_t k = 0; k < got.size(); ++k) EXPECT_NEAR(got[k], want[k], 1e-12) << what;
}

} // namespace

// Each probe samples at its own interval; interval 0 follows output.probe_interval.
TEST(Probes, EachProbeSamplesAtItsInterval) {
  const auto dir = test::scratch_dir("run");
  FakeSource src;
  output::ProbeSetOptions o;
  o.base_interval = 0.01;
  output::ProbeSet set(probe_scene(), src, o);
  set.open(dir);
  EXPECT_DOUBLE_EQ(set.finest_interval(), 0.01);
  run_steps(set, src, 0, 20);
  set.close();
  expect_times(times_of(dir / "energy.csv"), expected(0.05, 0.1), "energy");
  expect_times(times_of(dir / "coordination.csv"), expected(0.01, 0.1), "coordination");
  expect_times(times_of(dir / "surface.csv"), expected(0.02, 0.1), "surface");
  expect_times(times_of(dir / "pressure_wall.csv"), expected(0.03, 0.1), "pressure");
  expect_times(times_of(dir / "loci.csv"), expected(0.01, 0.1), "loci");
  // structures.csv and walls.csv (a structure of kind wall) on the base interval
  expect_times(times_of(dir / "structures.csv"), expected(0.01, 0.1), "structures");
  expect_times(times_of(dir / "walls.csv"), expected(0.01, 0.1), "walls");
  // the columns
  EXPECT_EQ(output::read_csv(dir / "loci.csv").columns,
            (std::vector<std::string>{"time [s]", "p7.x [m]", "p7.z [m]", "p8.x [m]", "p8.z [m]"}));
  EXPECT_EQ(output::read_csv(dir / "pressure_wall.csv").columns,
            (std::vector<std::string>{"time [s]", "wall.bin0 [Pa]", "wall.bin1 [Pa]"}));
  EXPECT_EQ(output::read_csv(dir / "structures.csv").columns.size(), 1u + 7u);
  // a row holds the source's values at its time
  const auto e = output::read_csv(dir / "energy.csv");
  EXPECT_EQ(e.column("kinetic"), e.column("time"));
}

// The end of a run samples every probe once more, at the end time; a checkpoint's state restores
// the schedules so that a resumed run samples where the straight one does.
TEST(Probes, EndRowsAndRestoredSchedules) {
  const auto dir = test::scratch_dir("straight"), split = test::scratch_dir("split");
  FakeSource src;
  output::ProbeSetOptions o;
  o.base_interval = 0.01;
  {
    output::ProbeSet set(probe_scene(), src, o);
    set.open(dir);
    run_steps(set, src, 0, 21);
    src.t = 0.1075;
    set.sample_missing(src);
  }
  output::ProbeSet::State st;
  {
    output::ProbeSet set(probe_scene(), src, o);
    set.open(split);
    run_steps(set, src, 0, 9);
    st = set.state();
    EXPECT_EQ(st.next_own.size(), 3u); // energy, surface, pressure
    EXPECT_EQ(st.traced, (std::vector<std::uint32_t>{7, 8}));
  }
  {
    auto ro = o;
    ro.csv.resume_after = 0.045 - 0.0025;
    output::ProbeSet set(probe_scene(), src, ro, &st);
    set.open(split);
    run_steps(set, src, 10, 21);
    src.t = 0.1075;
    set.sample_missing(src);
  }
  for (const char* f : {"energy.csv", "coordination.csv", "surface.csv", "pressure_wall.csv",
                        "loci.csv", "structures.csv", "walls.csv"}) {
    const auto a = times_of(dir / f);
    EXPECT_EQ(a, times_of(split / f)) << f;
    EXPECT_EQ(a.back(), 0.1075) << f;
  }
}

// A solver without particles (the continuum) builds no particle probes and says so.
TEST(Probes, ProbesASolverCannotServeAreListed) {
  FakeSource src;
  src.particles = false;
  output::ProbeSetOptions o;
  o.write = false;
  o.load_histories = true;
  output::ProbeSet set(probe_scene(), src, o);
  std::vector<std::string> files;
  for (std::size_t k = 0; k < set.size(); ++k) files.push_back(set.probe(k).file());
  EXPECT_EQ(files, (std::vector<std::string>{"structures.csv", "walls.csv", "pressure_wall.csv"}));
  EXPECT_EQ(set.not_recorded().size(), 4u);          // energy, coordination, surface, loci
  EXPECT_EQ(set.probe(0).columns().size(), 1u + 9u); // with the load histories
}
