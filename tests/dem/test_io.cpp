// DEM I/O layer: VTK snapshots read back through VTK, .pvd collections, CSV series, checkpoints.
#include <gtest/gtest.h>

#include "../scratch.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <csignal>

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wpedantic"
#endif
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkStringArray.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLDataParser.h>
#include <vtkXMLPolyDataReader.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#include "demfem/dem/io.hpp"

namespace fs = std::filesystem;
using namespace demfem::dem;

namespace {

class IoTest : public ::testing::Test {
protected:
  void SetUp() override { dir_ = demfem::test::scratch_dir("io"); }
  fs::path dir_;
};

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// n particles with distinct, non-round values in every array; particle 2 is removed.
Particles make_particles(std::size_t n) {
  Particles p;
  for (std::size_t k = 0; k < n; ++k) {
    const double d = static_cast<double>(k);
    p.x.push_back(0.1 * d + 1.0 / 3.0);
    p.z.push_back(-0.2 * d + 1.0 / 7.0);
    p.phi.push_back(0.01 * d);
    p.vx.push_back(3.0 + d);
    p.vz.push_back(-4.0 + 0.5 * d);
    p.omega.push_back(0.25 * d - 1.0);
    p.fx.push_back(10.0 * d + 0.125);
    p.fz.push_back(-9.81 * (d + 1.0));
    p.torque.push_back(1e-3 * d);
    p.radius.push_back(0.005 + 1e-4 * d);
    p.mass.push_back(2.0 + d);
    p.inv_mass.push_back(1.0 / (2.0 + d));
    p.inv_inertia.push_back(1.0 / (0.5 + d));
    p.id.push_back(static_cast<std::uint32_t>(100 + k));
    p.material.push_back(static_cast<std::uint16_t>(k % 3));
    p.flags.push_back(k == 2 ? kFlagRemoved : (k == 1 ? kFlagTagged : kFlagNone));
  }
  return p;
}

vtkSmartPointer<vtkPolyData> read_vtp(const fs::path& p) {
  vtkNew<vtkXMLPolyDataReader> reader;
  reader->SetFileName(p.c_str());
  reader->Update();
  EXPECT_EQ(reader->GetErrorCode(), 0u) << p;
  vtkSmartPointer<vtkPolyData> out = reader->GetOutput();
  return out;
}

vtkDataArray* array_of(vtkFieldData* data, const char* name, int components) {
  vtkDataArray* a = data->GetArray(name);
  EXPECT_NE(a, nullptr) << "missing array " << name;
  if (a != nullptr) {
    EXPECT_EQ(a->GetNumberOfComponents(), components) << name;
  }
  return a;
}

bool no_tmp_files(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".tmp") return false;
  }
  return true;
}

template <class T> bool bit_equal(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

} // namespace

TEST_F(IoTest, NumberedFileName) {
  EXPECT_EQ(io::numbered_file_name("particles", 42, "vtp"), "particles_000042.vtp");
  EXPECT_EQ(io::numbered_file_name("contacts", 1234567, ".vtp"), "contacts_1234567.vtp");
}

TEST_F(IoTest, ParticlesVtpReadsBackThroughVtk) {
  const Particles p = make_particles(7);
  const fs::path file = dir_ / "particles_000000.vtp";
  io::write_particles_vtp(file, p);
  EXPECT_TRUE(no_tmp_files(dir_));

  // Binary, zlib-compressed, appended raw data.
  const std::string text = read_text(file);
  EXPECT_NE(text.find("compressor=\"vtkZLibDataCompressor\""), std::string::npos);
  EXPECT_NE(text.find("<AppendedData encoding=\"raw\">"), std::string::npos);
  EXPECT_NE(text.find("format=\"appended\""), std::string::npos);

  auto poly = read_vtp(file);
  ASSERT_NE(poly, nullptr);
  const vtkIdType n = 6; // particle 2 removed
  ASSERT_EQ(poly->GetNumberOfPoints(), n);
  EXPECT_EQ(poly->GetNumberOfVerts(), n);
  EXPECT_EQ(poly->GetNumberOfCells(), n);

  vtkPointData* pd = poly->GetPointData();
  vtkDataArray* id = array_of(pd, "id", 1);
  vtkDataArray* radius = array_of(pd, "radius", 1);
  vtkDataArray* diameter = array_of(pd, "diameter", 1);
  vtkDataArray* velocity = array_of(pd, "velocity", 3);
  vtkDataArray* omega = array_of(pd, "angular_velocity", 1);
  vtkDataArray* rotation = array_of(pd, "rotation", 1);
  vtkDataArray* force = array_of(pd, "force", 3);
  vtkDataArray* material = array_of(pd, "material", 1);
  vtkDataArray* speed = array_of(pd, "speed", 1);
  ASSERT_TRUE(id && radius && diameter && velocity && omega && rotation && force && material &&
              speed);
  EXPECT_EQ(id->GetDataType(), VTK_UNSIGNED_INT);
  EXPECT_EQ(material->GetDataType(), VTK_UNSIGNED_SHORT);
  EXPECT_EQ(radius->GetDataType(), VTK_DOUBLE);

  std::vector<std::size_t> expected_index = {0, 1, 3, 4, 5, 6};
  for (vtkIdType v = 0; v < n; ++v) {
    const std::size_t k = expected_index[static_cast<std::size_t>(v)];
    SCOPED_TRACE(::testing::Message() << "point " << v << " particle " << k);
    double pt[3];
    poly->GetPoint(v, pt);
    EXPECT_EQ(pt[0], p.x[k]);
    EXPECT_EQ(pt[1], p.z[k]);
    EXPECT_EQ(pt[2], 0.0);
    EXPECT_EQ(id->GetTuple1(v), p.id[k]);
    EXPECT_EQ(radius->GetTuple1(v), p.radius[k]);
    EXPECT_EQ(diameter->GetTuple1(v), 2.0 * p.radius[k]);
    EXPECT_EQ(velocity->GetComponent(v, 0), p.vx[k]);
    EXPECT_EQ(velocity->GetComponent(v, 1), p.vz[k]);
    EXPECT_EQ(velocity->GetComponent(v, 2), 0.0);
    EXPECT_EQ(omega->GetTuple1(v), p.omega[k]);
    EXPECT_EQ(rotation->GetTuple1(v), p.phi[k]);
    EXPECT_EQ(force->GetComponent(v, 0), p.fx[k]);
    EXPECT_EQ(force->GetComponent(v, 1), p.fz[k]);
    EXPECT_EQ(force->GetComponent(v, 2), 0.0);
    EXPECT_EQ(material->GetTuple1(v), p.material[k]);
    EXPECT_DOUBLE_EQ(speed->GetTuple1(v), std::hypot(p.vx[k], p.vz[k]));
  }
}

// [output] vtk_compression: lz4 and none write files that VTK reads back to the same values as
// zlib's, with the compressor named (lz4) or absent (none).
TEST_F(IoTest, SnapshotCompressionChoicesReadBackTheSame) {
  const Particles p = make_particles(2000);
  const fs::path zf = dir_ / "z.vtp", lf = dir_ / "l.vtp", nf = dir_ / "n.vtp";
  io::write_particles_vtp(zf, p);
  io::write_particles_vtp(lf, p, demfem::scene::VtkCompression::Lz4);
  io::write_particles_vtp(nf, p, demfem::scene::VtkCompression::None);
  EXPECT_NE(read_text(zf).find("compressor=\"vtkZLibDataCompressor\""), std::string::npos);
  EXPECT_NE(read_text(lf).find("compressor=\"vtkLZ4DataCompressor\""), std::string::npos);
  EXPECT_EQ(read_text(nf).find("compressor="), std::string::npos);
  EXPECT_GT(fs::file_size(nf), fs::file_size(zf));
  const auto z = read_vtp(zf), l = read_vtp(lf), n = read_vtp(nf);
  ASSERT_EQ(l->GetNumberOfPoints(), z->GetNumberOfPoints());
  ASSERT_EQ(n->GetNumberOfPoints(), z->GetNumberOfPoints());
  for (const char* name : {"id", "radius", "velocity", "force", "material", "speed"}) {
    SCOPED_TRACE(name);
    vtkDataArray* a = z->GetPointData()->GetArray(name);
    ASSERT_NE(a, nullptr);
    for (const auto& other : {l, n}) {
      vtkDataArray* b = other->GetPointData()->GetArray(name);
      ASSERT_NE(b, nullptr);
      ASSERT_EQ(b->GetNumberOfValues(), a->GetNumberOfValues());
      for (vtkIdType v = 0; v < a->GetNumberOfTuples(); ++v)
        for (int c = 0; c < a->GetNumberOfComponents(); ++c)
          ASSERT_EQ(b->GetComponent(v, c), a->GetComponent(v, c)) << v;
    }
  }
  for (vtkIdType v = 0; v < z->GetNumberOfPoints(); ++v) {
    double a[3], b[3];
    z->GetPoint(v, a);
    l->GetPoint(v, b);
    ASSERT_EQ(a[0], b[0]);
    ASSERT_EQ(a[1], b[1]);
  }
}

// Writing snapshots leaves no thread behind. (VTK's range computation through vtkSMPTools on
// Debian's TBB backend started a worker that spun in sched_yield after every write, on the core
// the other job or DEM thread needed; ctest runs each test in its own process, so the count before
// is this process's own.)
TEST_F(IoTest, SnapshotWritesStartNoThread) {
  auto threads = [] {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator("/proc/self/task")) ++n;
    return n;
  };
  const std::size_t before = threads();
  const Particles p = make_particles(5000);
  for (int k = 0; k < 3; ++k)
    io::write_particles_vtp(dir_ / io::numbered_file_name("particles", k, "vtp"), p);
  EXPECT_EQ(threads(), before);
}

// A snapshot that cannot be written names its file and the system's reason.
TEST_F(IoTest, UnwritableVtpNamesTheFileAndTheCause) {
  const fs::path file = dir_ / "no-such-folder" / "particles_000000.vtp";
  try {
    io::write_particles_vtp(file, make_particles(7));
    FAIL() << "no error";
  } catch (const io::IoError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file.string()), std::string::npos) << what;
    EXPECT_NE(what.find("No such file or directory"), std::string::npos) << what;
  }
  EXPECT_TRUE(no_tmp_files(dir_));
}

TEST_F(IoTest, EmptyParticlesVtpIsReadable) {
  const fs::path file = dir_ / "empty.vtp";
  io::write_particles_vtp(file, Particles{});
  auto poly = read_vtp(file);
  ASSERT_NE(poly, nullptr);
  EXPECT_EQ(poly->GetNumberOfPoints(), 0);
}

TEST_F(IoTest, InconsistentParticlesAreRefused) {
  Particles p = make_particles(3);
  p.radius.pop_back();
  EXPECT_THROW(io::write_particles_vtp(dir_ / "bad.vtp", p), io::IoError);
  EXPECT_FALSE(fs::exists(dir_ / "bad.vtp"));
}

TEST_F(IoTest, ForceChainsVtpReadsBack) {
  const Particles p = make_particles(5);
  std::vector<ContactView> contacts;
  contacts.push_back({0, 1, 0.5, 0.5, 12.5, -3.25, false});
  contacts.push_back({3, -3, 0.25, -0.5, 99.0, 1.0, false}); // particle 3 on boundary 2
  contacts.push_back({4, 3, 0.1, 0.2, -0.75, 0.5, true});
  const fs::path file = dir_ / "contacts.vtp";
  io::write_force_chains_vtp(file, p, contacts);
  EXPECT_TRUE(no_tmp_files(dir_));

  auto poly = read_vtp(file);
  ASSERT_NE(poly, nullptr);
  ASSERT_EQ(poly->GetNumberOfLines(), 3);
  ASSERT_EQ(poly->GetNumberOfCells(), 3);
  vtkCellData* cd = poly->GetCellData();
  vtkDataArray* fn = array_of(cd, "normal_force", 1);
  vtkDataArray* fs_ = array_of(cd, "shear_force", 1);
  vtkDataArray* tensile = array_of(cd, "tensile", 1);
  vtkDataArray* boundary = array_of(cd, "boundary", 1);
  ASSERT_TRUE(fn && fs_ && tensile && boundary);

  vtkNew<vtkIdList> ids;
  for (vtkIdType c = 0; c < 3; ++c) {
    SCOPED_TRACE(::testing::Message() << "contact " << c);
    const ContactView& k = contacts[static_cast<std::size_t>(c)];
    poly->GetCellPoints(c, ids);
    ASSERT_EQ(ids->GetNumberOfIds(), 2);
    double a[3], b[3];
    poly->GetPoint(ids->GetId(0), a);
    poly->GetPoint(ids->GetId(1), b);
    EXPECT_EQ(a[0], p.x[k.i]);
    EXPECT_EQ(a[1], p.z[k.i]);
    if (k.j >= 0) { // pair: to the other centre
      EXPECT_EQ(b[0], p.x[static_cast<std::size_t>(k.j)]);
      EXPECT_EQ(b[1], p.z[static_cast<std::size_t>(k.j)]);
      EXPECT_EQ(boundary->GetTuple1(c), -1.0);
    } else { // boundary: to the contact point, with the boundary's index
      EXPECT_EQ(b[0], k.cx);
      EXPECT_EQ(b[1], k.cz);
      EXPECT_EQ(boundary->GetTuple1(c), 2.0);
    }
    EXPECT_EQ(fn->GetTuple1(c), k.fn);
    EXPECT_EQ(fs_->GetTuple1(c), k.fs);
    EXPECT_EQ(tensile->GetTuple1(c), k.tensile ? 1.0 : 0.0);
  }

  contacts.push_back({0, 5, 0.0, 0.0, 1.0, 0.0, false}); // j beyond the particles
  EXPECT_THROW(io::write_force_chains_vtp(dir_ / "bad.vtp", p, contacts), io::IoError);
}

TEST_F(IoTest, BoundariesVtpReadsBack) {
  std::vector<BoundaryView> b(2);
  b[0].name = "left wall";
  b[0].x = {0.0, 0.0};
  b[0].z = {0.0, 2.0};
  b[0].open = true;
  b[1].name = "footing";
  b[1].x = {1.0, 2.0, 2.0, 1.0};
  b[1].z = {1.0, 1.0, 1.5, 1.5};
  b[1].closed = true;
  const fs::path file = dir_ / "boundaries.vtp";
  io::write_boundaries_vtp(file, b);

  auto poly = read_vtp(file);
  ASSERT_NE(poly, nullptr);
  ASSERT_EQ(poly->GetNumberOfLines(), 2);
  EXPECT_EQ(poly->GetNumberOfPoints(), 6);
  vtkNew<vtkIdList> ids;
  poly->GetCellPoints(0, ids);
  ASSERT_EQ(ids->GetNumberOfIds(), 2);
  double pt[3];
  poly->GetPoint(ids->GetId(1), pt);
  EXPECT_EQ(pt[0], 0.0);
  EXPECT_EQ(pt[1], 2.0);
  poly->GetCellPoints(1, ids);
  ASSERT_EQ(ids->GetNumberOfIds(), 5); // closed: first vertex repeated
  EXPECT_EQ(ids->GetId(0), ids->GetId(4));
  for (vtkIdType k = 0; k < 4; ++k) {
    poly->GetPoint(ids->GetId(k), pt);
    EXPECT_EQ(pt[0], b[1].x[static_cast<std::size_t>(k)]);
    EXPECT_EQ(pt[1], b[1].z[static_cast<std::size_t>(k)]);
  }

  vtkCellData* cd = poly->GetCellData();
  vtkDataArray* open = array_of(cd, "open", 1);
  vtkDataArray* closed = array_of(cd, "closed", 1);
  vtkDataArray* index = array_of(cd, "boundary_index", 1);
  ASSERT_TRUE(open && closed && index);
  EXPECT_EQ(open->GetTuple1(0), 1.0);
  EXPECT_EQ(open->GetTuple1(1), 0.0);
  EXPECT_EQ(closed->GetTuple1(0), 0.0);
  EXPECT_EQ(closed->GetTuple1(1), 1.0);
  EXPECT_EQ(index->GetTuple1(1), 1.0);
  auto* names = vtkStringArray::SafeDownCast(poly->GetFieldData()->GetAbstractArray("names"));
  ASSERT_NE(names, nullptr);
  ASSERT_EQ(names->GetNumberOfValues(), 2);
  EXPECT_EQ(names->GetValue(0), "left wall");
  EXPECT_EQ(names->GetValue(1), "footing");

  b[0].z.pop_back();
  EXPECT_THROW(io::write_boundaries_vtp(dir_ / "bad.vtp", b), io::IoError);
}

namespace {
struct PvdEntry {
  double time;
  std::string file;
};
// Parses a .pvd with VTK's XML parser; fails the test when it is not well-formed.
std::vector<PvdEntry> parse_pvd(const fs::path& p) {
  vtkNew<vtkXMLDataParser> parser;
  parser->SetFileName(p.c_str());
  std::vector<PvdEntry> out;
  EXPECT_EQ(parser->Parse(), 1) << "not well-formed XML: " << p;
  vtkXMLDataElement* root = parser->GetRootElement();
  if (root == nullptr) return out;
  EXPECT_STREQ(root->GetName(), "VTKFile");
  EXPECT_STREQ(root->GetAttribute("type"), "Collection");
  vtkXMLDataElement* coll = root->FindNestedElementWithName("Collection");
  EXPECT_NE(coll, nullptr);
  if (coll == nullptr) return out;
  for (int k = 0; k < coll->GetNumberOfNestedElements(); ++k) {
    vtkXMLDataElement* e = coll->GetNestedElement(k);
    EXPECT_STREQ(e->GetName(), "DataSet");
    double t = -1.0;
    EXPECT_EQ(e->GetScalarAttribute("timestep", t), 1);
    const char* f = e->GetAttribute("file");
    EXPECT_NE(f, nullptr);
    out.push_back({t, f != nullptr ? f : ""});
  }
  return out;
}
} // namespace

TEST_F(IoTest, PvdIsRewrittenAfterEveryAddition) {
  const fs::path pvd = dir_ / "particles.pvd";
  io::PvdCollection c(pvd);
  EXPECT_FALSE(fs::exists(pvd));
  c.add(0.0, dir_ / "particles_000000.vtp");
  auto e = parse_pvd(pvd);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].file, "particles_000000.vtp"); // stored relative to the .pvd

  c.add(0.1, "particles_000001.vtp");
  c.add(1.0 / 3.0, "sub dir/a&b.vtp");
  e = parse_pvd(pvd);
  ASSERT_EQ(e.size(), 3u);
  EXPECT_EQ(e[0].time, 0.0);
  EXPECT_EQ(e[1].time, 0.1);
  EXPECT_EQ(e[2].time, 1.0 / 3.0); // printed with round-trip precision
  EXPECT_EQ(e[1].file, "particles_000001.vtp");
  EXPECT_EQ(e[2].file, "sub dir/a&b.vtp"); // XML-escaped on disk
  EXPECT_NE(read_text(pvd).find("a&amp;b.vtp"), std::string::npos);
  EXPECT_TRUE(no_tmp_files(dir_));
  EXPECT_EQ(c.entries().size(), 3u);
}

TEST_F(IoTest, PvdResumeDropsEntriesAfterTheCheckpoint) {
  const fs::path pvd = dir_ / "contacts.pvd";
  {
    io::PvdCollection c(pvd);
    for (int k = 0; k < 5; ++k) c.add(0.5 * k, io::numbered_file_name("contacts", k, "vtp"));
  }
  io::PvdCollection r = io::PvdCollection::resume(pvd, 1.0);
  ASSERT_EQ(r.entries().size(), 3u);
  EXPECT_EQ(r.entries()[2].file, "contacts_000002.vtp");
  r.add(1.25, "contacts_000005.vtp");
  const auto e = parse_pvd(pvd);
  ASSERT_EQ(e.size(), 4u);
  EXPECT_EQ(e[3].time, 1.25);

  EXPECT_TRUE(io::PvdCollection::resume(dir_ / "missing.pvd", 1.0).entries().empty());
  std::ofstream(dir_ / "broken.pvd") << "<VTKFile type=\"Collection\"><Collection><DataSet";
  EXPECT_THROW((void)io::PvdCollection::resume(dir_ / "broken.pvd", 1.0), io::IoError);
}

namespace {
Particles tricky_particles() {
  Particles p = make_particles(9);
  const double qnan_payload = std::bit_cast<double>(0x7ff8000000012345ull);
  p.x[0] = -0.0;
  p.x[1] = std::numeric_limits<double>::denorm_min();
  p.z[2] = std::numeric_limits<double>::infinity();
  p.vz[3] = qnan_payload;
  p.omega[4] = std::numeric_limits<double>::max();
  p.id[5] = 0xFFFFFFFFu;
  p.material[6] = 0xFFFF;
  p.flags[7] = 0xDEADBEEFu;
  return p;
}

std::vector<std::byte> blob(std::size_t n) {
  std::vector<std::byte> b(n);
  for (std::size_t k = 0; k < n; ++k) b[k] = static_cast<std::byte>((k * 131 + 7) & 0xFF);
  return b;
}

void expect_bit_equal(const Particles& a, const Particles& b) {
  EXPECT_TRUE(bit_equal(a.x, b.x));
  EXPECT_TRUE(bit_equal(a.z, b.z));
  EXPECT_TRUE(bit_equal(a.phi, b.phi));
  EXPECT_TRUE(bit_equal(a.vx, b.vx));
  EXPECT_TRUE(bit_equal(a.vz, b.vz));
  EXPECT_TRUE(bit_equal(a.omega, b.omega));
  EXPECT_TRUE(bit_equal(a.fx, b.fx));
  EXPECT_TRUE(bit_equal(a.fz, b.fz));
  EXPECT_TRUE(bit_equal(a.torque, b.torque));
  EXPECT_TRUE(bit_equal(a.radius, b.radius));
  EXPECT_TRUE(bit_equal(a.mass, b.mass));
  EXPECT_TRUE(bit_equal(a.inv_mass, b.inv_mass));
  EXPECT_TRUE(bit_equal(a.inv_inertia, b.inv_inertia));
  EXPECT_TRUE(bit_equal(a.id, b.id));
  EXPECT_TRUE(bit_equal(a.material, b.material));
  EXPECT_TRUE(bit_equal(a.flags, b.flags));
}

// Expects read_checkpoint to throw IoError whose message names the file and contains `what`.
void expect_read_error(const fs::path& p, const std::string& what) {
  try {
    (void)io::read_checkpoint(p);
    ADD_FAILURE() << "no error reading " << p << " (expected: " << what << ")";
  } catch (const io::IoError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(p.string()), std::string::npos) << msg;
    EXPECT_NE(msg.find(what), std::string::npos) << "expected '" << what << "' in: " << msg;
  }
}

std::vector<char> read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& p, const std::vector<char>& b) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(b.data(), static_cast<std::streamsize>(b.size()));
}
} // namespace

TEST_F(IoTest, CheckpointRoundTripIsBitExact) {
  const Particles p = tricky_particles();
  io::CheckpointMeta meta;
  meta.time = 1.0 / 3.0;
  meta.step = 1234567890123;
  meta.dt = 2.5e-6;
  meta.label = "footing / case-2";
  const auto extra = blob(1001);
  const fs::path file = dir_ / "checkpoint.bin";
  io::write_checkpoint(file, p, meta, extra);
  EXPECT_TRUE(no_tmp_files(dir_));

  const io::Checkpoint cp = io::read_checkpoint(file);
  expect_bit_equal(p, cp.particles);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(cp.meta.time), std::bit_cast<std::uint64_t>(meta.time));
  EXPECT_EQ(cp.meta.step, meta.step);
  EXPECT_EQ(cp.meta.dt, meta.dt);
  EXPECT_EQ(cp.meta.label, meta.label);
  EXPECT_EQ(cp.extra, extra);
  EXPECT_EQ(cp.particles.size(), p.size());

  // Overwriting an existing checkpoint replaces it.
  io::write_checkpoint(file, Particles{}, io::CheckpointMeta{}, {});
  const io::Checkpoint empty = io::read_checkpoint(file);
  EXPECT_EQ(empty.particles.size(), 0u);
  EXPECT_TRUE(empty.extra.empty());
  EXPECT_TRUE(empty.meta.label.empty());
}

TEST_F(IoTest, CheckpointRefusesInconsistentParticles) {
  Particles p = make_particles(4);
  p.inv_inertia.pop_back();
  EXPECT_THROW(io::write_checkpoint(dir_ / "cp.bin", p, {}, {}), io::IoError);
  EXPECT_FALSE(fs::exists(dir_ / "cp.bin"));
  EXPECT_TRUE(no_tmp_files(dir_));
}

// A checkpoint that cannot be written (here: the process may not grow a file past 4 KiB, as on a
// full disk) fails naming the checkpoint itself, not its temporary "<path>.tmp", with the cause,
// and leaves neither a partial checkpoint nor the temporary file behind. The same for a
// checkpoint whose directory is a regular file.
TEST_F(IoTest, FailedCheckpointWriteNamesTheFileAndTheCause) {
  const fs::path file = dir_ / "checkpoint.ckpt";
  const Particles p = make_particles(2000); // ≫ 4 KiB
  std::string message;
  {
    struct rlimit old {};
    ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
    struct rlimit small = old;
    small.rlim_cur = 4096;
    const auto old_handler = std::signal(SIGXFSZ, SIG_IGN); // EFBIG instead of a signal
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
    try {
      io::write_checkpoint(file, p, {.time = 1.0, .step = 1, .dt = 1e-5, .label = "x"}, {});
    } catch (const io::IoError& e) {
      message = e.what();
    }
    ::setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, old_handler);
  }
  EXPECT_NE(message.find("cannot write '" + file.string() + "': File too large"), std::string::npos)
      << message;
  EXPECT_EQ(message.find(".tmp'"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(file));
  EXPECT_TRUE(no_tmp_files(dir_));

  std::ofstream(dir_ / "not_a_dir") << "x";
  const fs::path under_file = dir_ / "not_a_dir" / "checkpoint.ckpt";
  try {
    io::write_checkpoint(under_file, p, {}, {});
    ADD_FAILURE() << "no error";
  } catch (const io::IoError& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("cannot write '" + under_file.string() + "': Not a directory"),
            std::string::npos)
      << message;
}

TEST_F(IoTest, DamagedCheckpointsGiveClearErrors) {
  const fs::path good = dir_ / "good.bin";
  io::write_checkpoint(good, tricky_particles(),
                       {.time = 2.0, .step = 10, .dt = 1e-5, .label = "x"}, blob(64));
  const std::vector<char> bytes = read_bytes(good);
  ASSERT_GT(bytes.size(), 200u);
  const fs::path bad = dir_ / "bad.bin";

  expect_read_error(dir_ / "missing.bin", "cannot open");

  write_bytes(bad, {});
  expect_read_error(bad, "not a demfem checkpoint");

  std::vector<char> b = bytes;
  b[0] = 'X';
  write_bytes(bad, b);
  expect_read_error(bad, "bad magic");

  b = bytes;
  b[8] = 99; // format version
  write_bytes(bad, b);
  expect_read_error(bad, "unsupported format version 99");

  b = bytes;
  std::swap(b[12], b[15]); // byte-order marker 0x01020304 → 0x04030201
  std::swap(b[13], b[14]);
  write_bytes(bad, b);
  expect_read_error(bad, "other byte order");

  // Truncation anywhere after the fixed header is reported as such.
  for (const std::size_t len : {std::size_t{12}, std::size_t{20}, std::size_t{60}, bytes.size() / 2,
                                bytes.size() - 9, bytes.size() - 1}) {
    SCOPED_TRACE(::testing::Message() << "truncated to " << len << " of " << bytes.size());
    write_bytes(bad, std::vector<char>(bytes.begin(), bytes.begin() + static_cast<long>(len)));
    expect_read_error(bad, "truncated");
  }

  // A flipped bit in the particle data is caught by the checksum.
  b = bytes;
  b[b.size() / 2] = static_cast<char>(b[b.size() / 2] ^ 0x10);
  write_bytes(bad, b);
  expect_read_error(bad, "checksum mismatch");

  // Trailing garbage.
  b = bytes;
  b.push_back('!');
  write_bytes(bad, b);
  expect_read_error(bad, "checksum mismatch");

  // The intact file still reads.
  EXPECT_NO_THROW((void)io::read_checkpoint(good));
}
