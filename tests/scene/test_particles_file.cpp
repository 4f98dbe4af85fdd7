// soil.dem.particles_file: particle sets from a .csv or .npy file named in the scene, with the
// path taken relative to the scene file and every problem located (file:line:col).
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "../scratch.hpp"

#include "demfem/app/vocabulary.hpp"
#include "demfem/scene/load.hpp"
#include "demfem/scene/particles_file.hpp"
#include "demfem/scene/validate.hpp"

using namespace demfem::scene;
namespace fs = std::filesystem;

namespace {

class ParticlesFile : public ::testing::Test {
protected:
  void SetUp() override {
    dir_ = demfem::test::scratch_dir("pf");
    fs::create_directories(dir_ / "sub");
  }
  void write(const fs::path& rel, const std::string& text) {
    std::ofstream(dir_ / rel, std::ios::binary) << text;
  }
  // Scene in dir_/sub/scene.toml; dem_keys start on line 9.
  fs::path scene(const std::string& dem_keys) {
    write("sub/scene.toml", "[scene]\nname = \"f\"\nsolvers = [\"dem\"]\nduration = 0.1\n"
                            "[domain]\npolygon = [[0, 0], [120, 0], [120, 10], [0, 10]]\n"
                            "[soil.dem]\nradius = { equal = 0.1 }\n" +
                                dem_keys + "\n");
    return dir_ / "sub" / "scene.toml";
  }
  // The diagnostics of loading `path`; empty when it loads.
  static std::vector<Diagnostic> errors(const fs::path& path) {
    try {
      (void)load_scene_file(path, demfem::app::vocabulary());
    } catch (const SceneError& e) {
      return e.diagnostics();
    }
    return {};
  }
  fs::path dir_;
};

TEST_F(ParticlesFile, CsvRelativeToSceneWithHeaderAndComments) {
  write("sub/bed.csv", "# three disks\nx,z,r\n0.5, 0.1, 0.1\n\n1.5,0.1,0.12\n2.5,0.3,0.08\n");
  const auto sf = load_scene_file(scene("particles_file = \"bed.csv\""), demfem::app::vocabulary());
  const auto& d = *sf.base.soil.dem;
  ASSERT_EQ(d.particles.size(), 3u);
  EXPECT_EQ(d.count, 3); // count left out: taken from the file
  EXPECT_DOUBLE_EQ(d.particles[1][0], 1.5);
  EXPECT_DOUBLE_EQ(d.particles[1][2], 0.12);
  EXPECT_DOUBLE_EQ(d.particles[2][3], 0.0); // no velocity columns: at rest
  EXPECT_TRUE(fs::path(d.particles_file).is_absolute());
  EXPECT_EQ(fs::path(d.particles_file).filename(), "bed.csv");
}

TEST_F(ParticlesFile, SixColumnsAndParentDirectory) {
  write("up.csv", "1,2,0.5,3,4,5\n6,7,0.25,8,9,10\n");
  const auto sf = load_scene_file(scene("count = 2\nparticles_file = \"../up.csv\""),
                                  demfem::app::vocabulary());
  const auto& p = sf.base.soil.dem->particles;
  ASSERT_EQ(p.size(), 2u);
  EXPECT_DOUBLE_EQ(p[1][5], 10.0);
  EXPECT_DOUBLE_EQ(p[0][3], 3.0);
}

TEST_F(ParticlesFile, MissingFileLocatedAtTheKey) {
  const auto path = scene("count = 2\nparticles_file = \"nope.csv\"");
  const auto d = errors(path);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].file, path.string());
  EXPECT_EQ(d[0].line, 10);
  EXPECT_EQ(d[0].column, 18);
  EXPECT_EQ(d[0].key, "soil.dem.particles_file");
  EXPECT_NE(d[0].message.find("nope.csv"), std::string::npos) << d[0].message;
}

TEST_F(ParticlesFile, BadRowsLocatedAtFileLineColumn) {
  write("sub/bad.csv", "x,z,r\n0,0,0.1\n1, zz ,0.1\n2,0,-0.1\n3,0\n");
  auto all = errors(scene("particles_file = \"bad.csv\""));
  ASSERT_EQ(all.size(), 4u);
  // first where the scene names the file, then the file's own problems
  EXPECT_EQ(all[0].line, 9);
  EXPECT_EQ(fs::path(all[0].file).filename(), "scene.toml");
  EXPECT_NE(all[0].message.find("'bad.csv' is refused (3 problem(s)"), std::string::npos)
      << all[0].message;
  const std::vector<Diagnostic> d(all.begin() + 1, all.end());
  for (const auto& x : d) {
    EXPECT_EQ(fs::path(x.file).filename(), "bad.csv");
    EXPECT_EQ(x.key, "soil.dem.particles_file");
  }
  EXPECT_EQ(d[0].line, 3);
  EXPECT_EQ(d[0].column, 4); // "zz"
  EXPECT_NE(d[0].message.find("'zz'"), std::string::npos) << d[0].message;
  EXPECT_EQ(d[1].line, 4);
  EXPECT_EQ(d[1].column, 5); // the radius field
  EXPECT_NE(d[1].message.find("radius must be > 0"), std::string::npos);
  EXPECT_EQ(d[2].line, 5);
  EXPECT_NE(d[2].message.find("got 2"), std::string::npos);
  EXPECT_EQ(d[0].format().rfind(d[0].file + ":3:4: error: soil.dem.particles_file: ", 0), 0u)
      << d[0].format();
}

TEST_F(ParticlesFile, CountMismatchAndBothSources) {
  write("sub/two.csv", "0,0,0.1\n1,0,0.1\n");
  auto d = errors(scene("count = 3\nparticles_file = \"two.csv\""));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].key, "soil.dem.count");
  EXPECT_EQ(d[0].line, 9);
  d = errors(
      scene("count = 2\nparticles = [[0, 0, 0.1], [1, 0, 0.1]]\nparticles_file = \"two.csv\""));
  ASSERT_FALSE(d.empty());
  EXPECT_NE(d[0].message.find("not both"), std::string::npos);
  d = errors(scene("particles_file = \"two.txt\""));
  ASSERT_FALSE(d.empty()); // missing file: located at the key
  write("sub/two.txt", "0,0,0.1\n");
  d = errors(scene("particles_file = \"two.txt\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NE(d[1].message.find(".csv or .npy"), std::string::npos);
}

TEST_F(ParticlesFile, NpyRoundTripIsExact) {
  std::vector<ParticleRow> rows;
  for (int i = 0; i < 1000; ++i)
    rows.push_back({0.1 * i + 1e-17, 1.0 / (i + 3), 0.05 + 1e-4 * (i % 7), 0.3 * i, -0.1, 1.0 / 3});
  write_particles_file(dir_ / "sub" / "bed.npy", rows);
  write_particles_file(dir_ / "sub" / "bed.csv", rows);
  for (const char* name : {"bed.npy", "bed.csv"}) {
    const auto sf = load_scene_file(scene(std::string("particles_file = \"") + name + "\""),
                                    demfem::app::vocabulary());
    const auto& p = sf.base.soil.dem->particles;
    ASSERT_EQ(p.size(), rows.size()) << name;
    for (std::size_t i = 0; i < rows.size(); ++i)
      for (std::size_t k = 0; k < 6; ++k) ASSERT_EQ(p[i][k], rows[i][k]) << name << " " << i;
  }
}

TEST_F(ParticlesFile, NpyWrongShapeOrType) {
  // (N, 2) float64
  std::string h = "{'descr': '<f8', 'fortran_order': False, 'shape': (1, 2), }";
  h.append(128 - 10 - h.size() - 1, ' ');
  h += '\n';
  std::string b = std::string("\x93NUMPY\x01\x00", 8) + static_cast<char>(h.size()) + '\0' + h +
                  std::string(16, '\0');
  write("sub/bad.npy", b);
  auto d = errors(scene("particles_file = \"bad.npy\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NE(d[1].message.find("shape (N, 3) or (N, 6)"), std::string::npos) << d[1].message;
  write("sub/bad.npy", "not numpy at all");
  d = errors(scene("particles_file = \"bad.npy\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NE(d[1].message.find("magic"), std::string::npos);
}

TEST_F(ParticlesFile, ResolvedSceneKeepsTheFileNotAnInlineList) {
  write("sub/bed.csv", "0,0,0.1\n1,0,0.1\n");
  const auto sf = load_scene_file(scene("particles_file = \"bed.csv\"\nparticle_mass = \"sphere\""),
                                  demfem::app::vocabulary());
  const std::string t = to_toml(sf.base);
  EXPECT_NE(t.find("particles_file"), std::string::npos);
  EXPECT_EQ(t.find("particles = "), std::string::npos);
  write("resolved.toml", t); // another directory: the stored path is absolute
  const auto back = load_scene_file(dir_ / "resolved.toml", demfem::app::vocabulary());
  EXPECT_EQ(back.base.soil.dem->particles, sf.base.soil.dem->particles);
  EXPECT_TRUE(back.base.soil.dem->sphere_mass);
}

} // namespace

// Overlaps beyond max_overlap are found in a set of any size (a cell grid; the O(n²) scan it
// replaced stopped checking above 20,000 particles): a 30,000-disk lattice whose last two disks
// sit on disks 5 and 17 gives exactly those two errors, in file order.
TEST_F(ParticlesFile, OverlapsFoundInLargeSets) {
  std::string csv = "x,z,r\n";
  const int cols = 1000, n = 30000;
  for (int k = 0; k < n - 2; ++k)
    csv += fmt::format("{},{},0.05\n", 0.1 + 0.115 * (k % cols), 0.1 + 0.115 * (k / cols));
  for (const int k : {5, 17})
    csv += fmt::format("{},{},0.05\n", 0.1 + 0.115 * (k % cols) + 0.01, 0.1);
  write("sub/big.csv", csv);
  const auto d = errors(scene("particles_file = \"big.csv\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].key, "soil.dem.particles[29998]");
  EXPECT_NE(d[0].message.find("overlaps particle 5 by"), std::string::npos) << d[0].message;
  EXPECT_EQ(d[1].key, "soil.dem.particles[29999]");
  EXPECT_NE(d[1].message.find("overlaps particle 17 by"), std::string::npos) << d[1].message;
}

namespace {

// A version-1.0 .npy file: the header padded to a multiple of 64 bytes, then `data`.
std::string npy_bytes(const std::string& header, const std::string& data) {
  std::string h = header;
  h.append((64 - (10 + h.size() + 1) % 64) % 64, ' ');
  h += '\n';
  return std::string("\x93NUMPY\x01\x00", 8) + static_cast<char>(h.size() & 0xff) +
         static_cast<char>(h.size() >> 8) + h + data;
}

std::string doubles(std::initializer_list<double> v) {
  std::string s(v.size() * sizeof(double), '\0');
  std::size_t k = 0;
  for (const double x : v) std::memcpy(s.data() + sizeof(double) * k++, &x, sizeof(double));
  return s;
}

} // namespace

// Zero particles cannot be run (the run waited at t = 0 for ever): an .npy of shape (0, 3) and a
// CSV with only a header are refused, located at the scene's key and in the file.
TEST_F(ParticlesFile, ZeroParticlesRefused) {
  write("sub/none.npy",
        npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (0, 3), }", ""));
  auto d = errors(scene("particles_file = \"none.npy\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].line, 9);
  EXPECT_EQ(fs::path(d[1].file).filename(), "none.npy");
  EXPECT_NE(d[1].message.find("shape (0, 3): no particles"), std::string::npos) << d[1].message;
  EXPECT_NE(d[1].message.find("at byte 10"), std::string::npos) << d[1].message;
  write("sub/none.csv", "# nothing yet\nx,z,r\n\n");
  d = errors(scene("particles_file = \"none.csv\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NE(d[1].message.find("holds no particles"), std::string::npos) << d[1].message;
}

// A header claiming 2^61 rows (2^61 × 24 bytes wraps 64 bits to 0) is compared with the file's
// size without forming the product: refused as truncated, nothing allocated; a count beyond 64
// bits is no shape at all.
TEST_F(ParticlesFile, NpyHeaderCheckedAgainstTheFileSizeWithoutOverflow) {
  write("sub/huge.npy", npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': "
                                  "(2305843009213693952, 3), }",
                                  doubles({1, 1, 0.05})));
  auto d = errors(scene("particles_file = \"huge.npy\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NE(d[1].message.find("shape (2305843009213693952, 3) needs"), std::string::npos)
      << d[1].message;
  EXPECT_NE(d[1].message.find("room for 1 rows"), std::string::npos) << d[1].message;
  write("sub/huge.npy", npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': "
                                  "(99999999999999999999999, 3), }",
                                  doubles({1, 1, 0.05})));
  d = errors(scene("particles_file = \"huge.npy\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NE(d[1].message.find("must have shape (N, 3)"), std::string::npos) << d[1].message;
}

// Row cap and memory: refused before the rows are read (.npy, from its header) or as soon as
// they pass the limit (.csv, streamed), with the estimate and where the limit came from.
TEST_F(ParticlesFile, RowCapAndMemoryEstimateRefuseBeforeReadingEverything) {
  write("sub/three.csv", "x,z,r\n0,0,0.1\n1,0,0.1\n2,0,0.1\n");
  std::vector<Diagnostic> d;
  ParticleFileLimits cap;
  cap.max_rows = 2;
  EXPECT_TRUE(read_particles_file(dir_ / "sub/three.csv", "k", d, 20, cap).empty());
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].line, 4);
  EXPECT_NE(d[0].message.find("more than 2 particles"), std::string::npos) << d[0].message;

  ParticleFileLimits mem;
  mem.memory_bytes = 2.0 * kBytesPerParticle;
  mem.memory_source = "the test's limit";
  d.clear();
  EXPECT_TRUE(read_particles_file(dir_ / "sub/three.csv", "k", d, 20, mem).empty());
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].line, 4);
  EXPECT_NE(d[0].message.find("stopped reading here"), std::string::npos) << d[0].message;
  EXPECT_NE(d[0].message.find("(the test's limit)"), std::string::npos) << d[0].message;

  std::vector<ParticleRow> rows(1000, ParticleRow{1.0, 1.0, 0.05, 0.0, 0.0, 0.0});
  write_particles_file(dir_ / "sub" / "k.npy", rows);
  mem.memory_bytes = 10.0 * kBytesPerParticle;
  d.clear();
  EXPECT_TRUE(read_particles_file(dir_ / "sub/k.npy", "k", d, 20, mem).empty());
  ASSERT_EQ(d.size(), 1u);
  EXPECT_NE(d[0].message.find("1000 particles need about 1.02 MB of memory"), std::string::npos)
      << d[0].message;
  EXPECT_NE(d[0].message.find("at most about 10 particles fit"), std::string::npos) << d[0].message;
  mem.memory_bytes = 1000.0 * kBytesPerParticle; // just enough
  d.clear();
  EXPECT_EQ(read_particles_file(dir_ / "sub/k.npy", "k", d, 20, mem).size(), 1000u);
  EXPECT_TRUE(d.empty());
}

// Lines are read one at a time with a length cap: a file that is no CSV (one 100 kB line) is
// refused at its first line instead of being held whole.
TEST_F(ParticlesFile, CsvLinesHaveALengthCap) {
  write("sub/blob.csv", std::string(100000, '7') + "\n");
  const auto d = errors(scene("particles_file = \"blob.csv\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[1].line, 1);
  EXPECT_NE(d[1].message.find("longer than 4096 characters"), std::string::npos) << d[1].message;
}

// A UTF-8 byte-order mark, as spreadsheets export CSV, is skipped (it was "a bad header"); the
// columns of line 1 count from after it.
TEST_F(ParticlesFile, CsvWithAByteOrderMarkIsRead) {
  write("sub/excel.csv", "\xEF\xBB\xBFx,z,r\r\n0.5,0.1,0.1\r\n1.5,0.1,0.12\r\n");
  const auto sf =
      load_scene_file(scene("particles_file = \"excel.csv\""), demfem::app::vocabulary());
  ASSERT_EQ(sf.base.soil.dem->particles.size(), 2u);
  EXPECT_DOUBLE_EQ(sf.base.soil.dem->particles[1][2], 0.12);
  write("sub/excel.csv", "\xEF\xBB\xBF"
                         "0.5,zz,0.1\n");
  const auto d = errors(scene("particles_file = \"excel.csv\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[1].line, 1);
  EXPECT_EQ(d[1].column, 5);
}

// .npy problems name the byte (and the row) where they are.
TEST_F(ParticlesFile, NpyErrorsCarryByteAndRow) {
  write("sub/f4.npy", npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (1, 3), }",
                                std::string(12, '\0')));
  auto d = errors(scene("particles_file = \"f4.npy\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NE(d[1].message.find("at byte 10 (the header): .npy array must be little-endian"),
            std::string::npos)
      << d[1].message;
  write("sub/row.npy", npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }",
                                 doubles({1, 1, 0.05, 2, 1, -0.05})));
  d = errors(scene("particles_file = \"row.npy\""));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NE(d[1].message.find("row 1 (0-based), at byte 152"), std::string::npos) << d[1].message;
  EXPECT_EQ(d[1].format().rfind(d[1].file + ": error: soil.dem.particles_file: row 1", 0), 0u)
      << d[1].format();
}
