// VTK XML PolyData writers for particles, force chains and boundary outlines.
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>

#include <fmt/format.h>

#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wpedantic"
#endif
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDoubleArray.h>
#include <vtkErrorCode.h>
#include <vtkFieldData.h>
#include <vtkIdTypeArray.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>
#include <vtkUnsignedIntArray.h>
#include <vtkUnsignedShortArray.h>
#include <vtkXMLPolyDataWriter.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#include "atomic_file.hpp"
#include "demfem/dem/io.hpp"
#include "vtk_serial.hpp"

namespace demfem::dem::io {
namespace {

// Encodes through VTK in memory, writes "<path>.tmp" in one piece and renames it over path.
// (VTK writing the file itself made ≈ 1,400 small writes and position queries per snapshot of
// 3,400 disks: 72,000 system calls in a wall run.)
void write_polydata(const std::filesystem::path& path, vtkPolyData* poly,
                    scene::VtkCompression compression) {
  vtkNew<vtkXMLPolyDataWriter> writer;
  writer->SetInputData(poly);
  writer->WriteToOutputStringOn();
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff(); // raw binary, not base64
  switch (compression) {
  case scene::VtkCompression::Zlib:
    writer->SetCompressorTypeToZLib();
    writer->SetCompressionLevel(1); // fastest deflate: 1/5 of the time of VTK's default level 5
    break;
  case scene::VtkCompression::Lz4:
    writer->SetCompressorTypeToLZ4();
    writer->SetCompressionLevel(1); // LZ4's fastest
    break;
  case scene::VtkCompression::None:
    writer->SetCompressorTypeToNone();
    break;
  }
  writer->SetHeaderTypeToUInt64();
  int ok = 0;
  // On this thread: no TBB worker left spinning after the write (vtk_serial.hpp).
  detail::vtk_serially([&] { ok = writer->Write(); });
  if (ok != 1 || writer->GetErrorCode() != 0) {
    const unsigned long code = writer->GetErrorCode();
    const char* why = vtkErrorCode::GetStringFromErrorCode(code);
    throw IoError(fmt::format("cannot write '{}': {} (VTK error code {})", path.string(),
                              why != nullptr && *why != '\0' ? why : "the VTK writer failed",
                              code));
  }
  const std::string bytes = writer->GetOutputString();
  const std::filesystem::path tmp = detail::temporary_path(path);
  std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
  if (f) f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (f) f.close();
  if (!f) {
    const int err = errno;
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw IoError(fmt::format("cannot write '{}': {}", path.string(),
                              err != 0 ? std::strerror(err) : "the file could not be written"));
  }
  detail::rename_over(tmp, path);
}

template <class Array>
vtkNew<Array> make_array(const char* name, int components, vtkIdType tuples) {
  vtkNew<Array> a;
  a->SetName(name);
  a->SetNumberOfComponents(components);
  a->SetNumberOfTuples(tuples);
  return a;
}

void check_particle_arrays(const Particles& p, const std::filesystem::path& path) {
  const std::size_t n = p.size();
  const bool same = p.z.size() == n && p.phi.size() == n && p.vx.size() == n && p.vz.size() == n &&
                    p.omega.size() == n && p.fx.size() == n && p.fz.size() == n &&
                    p.radius.size() == n && p.id.size() == n && p.material.size() == n &&
                    p.flags.size() == n;
  if (!same) {
    throw IoError(
        fmt::format("cannot write '{}': the Particles arrays differ in length", path.string()));
  }
}

} // namespace

std::string numbered_file_name(const std::string& stem, long long index,
                               const std::string& extension) {
  std::string ext = extension;
  if (!ext.empty() && ext.front() != '.') ext.insert(ext.begin(), '.');
  return fmt::format("{}_{:06d}{}", stem, index, ext);
}

void write_particles_vtp(const std::filesystem::path& path, const Particles& p,
                         scene::VtkCompression compression) {
  check_particle_arrays(p, path);
  std::vector<std::size_t> keep;
  keep.reserve(p.size());
  for (std::size_t k = 0; k < p.size(); ++k) {
    if ((p.flags[k] & kFlagRemoved) == 0) keep.push_back(k);
  }
  const auto n = static_cast<vtkIdType>(keep.size());

  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(n);
  auto id = make_array<vtkUnsignedIntArray>("id", 1, n);
  auto radius = make_array<vtkDoubleArray>("radius", 1, n);
  auto diameter = make_array<vtkDoubleArray>("diameter", 1, n);
  auto velocity = make_array<vtkDoubleArray>("velocity", 3, n);
  auto omega = make_array<vtkDoubleArray>("angular_velocity", 1, n);
  auto rotation = make_array<vtkDoubleArray>("rotation", 1, n);
  auto force = make_array<vtkDoubleArray>("force", 3, n);
  auto material = make_array<vtkUnsignedShortArray>("material", 1, n);
  auto speed = make_array<vtkDoubleArray>("speed", 1, n);

  vtkNew<vtkIdTypeArray> offsets;
  offsets->SetNumberOfValues(n + 1);
  vtkNew<vtkIdTypeArray> connectivity;
  connectivity->SetNumberOfValues(n);
  offsets->SetValue(0, 0);

  for (vtkIdType v = 0; v < n; ++v) {
    const std::size_t k = keep[static_cast<std::size_t>(v)];
    points->SetPoint(v, p.x[k], p.z[k], 0.0);
    id->SetValue(v, p.id[k]);
    radius->SetValue(v, p.radius[k]);
    diameter->SetValue(v, 2.0 * p.radius[k]);
    velocity->SetTuple3(v, p.vx[k], p.vz[k], 0.0);
    omega->SetValue(v, p.omega[k]);
    rotation->SetValue(v, p.phi[k]);
    force->SetTuple3(v, p.fx[k], p.fz[k], 0.0);
    material->SetValue(v, p.material[k]);
    speed->SetValue(v, std::hypot(p.vx[k], p.vz[k]));
    connectivity->SetValue(v, v);
    offsets->SetValue(v + 1, v + 1);
  }

  vtkNew<vtkCellArray> verts;
  verts->SetData(offsets, connectivity);

  vtkNew<vtkPolyData> poly;
  poly->SetPoints(points);
  poly->SetVerts(verts);
  vtkPointData* pd = poly->GetPointData();
  pd->AddArray(id);
  pd->AddArray(radius);
  pd->AddArray(diameter);
  pd->AddArray(velocity);
  pd->AddArray(omega);
  pd->AddArray(rotation);
  pd->AddArray(force);
  pd->AddArray(material);
  pd->AddArray(speed);
  pd->SetActiveScalars("diameter");
  pd->SetActiveVectors("velocity");
  write_polydata(path, poly, compression);
}

void write_force_chains_vtp(const std::filesystem::path& path, const Particles& p,
                            std::span<const ContactView> contacts,
                            scene::VtkCompression compression) {
  if (p.z.size() != p.size()) {
    throw IoError(
        fmt::format("cannot write '{}': the Particles arrays differ in length", path.string()));
  }
  const std::size_t np = p.size();
  for (const ContactView& c : contacts) {
    if (c.i >= np || (c.j >= 0 && static_cast<std::uint64_t>(c.j) >= np)) {
      throw IoError(fmt::format("cannot write '{}': contact ({}, {}) refers to a particle "
                                "beyond the {} particles",
                                path.string(), c.i, c.j, np));
    }
  }
  const auto n = static_cast<vtkIdType>(contacts.size());

  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(2 * n);
  auto fn = make_array<vtkDoubleArray>("normal_force", 1, n);
  auto fs = make_array<vtkDoubleArray>("shear_force", 1, n);
  auto tensile = make_array<vtkUnsignedCharArray>("tensile", 1, n);
  auto boundary = make_array<vtkIntArray>("boundary", 1, n);
  vtkNew<vtkIdTypeArray> offsets;
  offsets->SetNumberOfValues(n + 1);
  offsets->SetValue(0, 0);
  vtkNew<vtkIdTypeArray> connectivity;
  connectivity->SetNumberOfValues(2 * n);

  vtkIdType c_out = 0;
  for (const ContactView& c : contacts) {
    const std::size_t a = c.i;
    points->SetPoint(2 * c_out, p.x[a], p.z[a], 0.0);
    if (c.j >= 0) { // particle pair: centre to centre
      const auto b = static_cast<std::size_t>(c.j);
      points->SetPoint(2 * c_out + 1, p.x[b], p.z[b], 0.0);
      boundary->SetValue(c_out, -1);
    } else { // particle–boundary: centre to the contact point on the boundary
      points->SetPoint(2 * c_out + 1, c.cx, c.cz, 0.0);
      boundary->SetValue(c_out, static_cast<int>(-1 - c.j));
    }
    connectivity->SetValue(2 * c_out, 2 * c_out);
    connectivity->SetValue(2 * c_out + 1, 2 * c_out + 1);
    offsets->SetValue(c_out + 1, 2 * (c_out + 1));
    fn->SetValue(c_out, c.fn);
    fs->SetValue(c_out, c.fs);
    tensile->SetValue(c_out, c.tensile ? 1 : 0);
    ++c_out;
  }

  vtkNew<vtkCellArray> lines;
  lines->SetData(offsets, connectivity);
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(points);
  poly->SetLines(lines);
  vtkCellData* cd = poly->GetCellData();
  cd->AddArray(fn);
  cd->AddArray(fs);
  cd->AddArray(tensile);
  cd->AddArray(boundary);
  cd->SetActiveScalars("normal_force");
  write_polydata(path, poly, compression);
}

void write_boundaries_vtp(const std::filesystem::path& path,
                          std::span<const BoundaryView> boundaries,
                          scene::VtkCompression compression) {
  vtkIdType n_points = 0;
  vtkIdType n_conn = 0;
  for (std::size_t b = 0; b < boundaries.size(); ++b) {
    const BoundaryView& v = boundaries[b];
    if (v.x.size() != v.z.size()) {
      throw IoError(fmt::format("cannot write '{}': boundary {} ('{}') has {} x and {} z "
                                "coordinates",
                                path.string(), b, v.name, v.x.size(), v.z.size()));
    }
    n_points += static_cast<vtkIdType>(v.x.size());
    n_conn += static_cast<vtkIdType>(v.x.size()) + (v.closed && !v.x.empty() ? 1 : 0);
  }
  const auto n_cells = static_cast<vtkIdType>(boundaries.size());

  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(n_points);
  vtkNew<vtkIdTypeArray> offsets;
  offsets->SetNumberOfValues(n_cells + 1);
  offsets->SetValue(0, 0);
  vtkNew<vtkIdTypeArray> connectivity;
  connectivity->SetNumberOfValues(n_conn);
  auto open = make_array<vtkUnsignedCharArray>("open", 1, n_cells);
  auto closed = make_array<vtkUnsignedCharArray>("closed", 1, n_cells);
  auto index = make_array<vtkIntArray>("boundary_index", 1, n_cells);
  vtkNew<vtkStringArray> names;
  names->SetName("names");
  names->SetNumberOfValues(n_cells);

  vtkIdType pt = 0;
  vtkIdType conn = 0;
  for (vtkIdType b = 0; b < n_cells; ++b) {
    const BoundaryView& v = boundaries[static_cast<std::size_t>(b)];
    const vtkIdType first = pt;
    for (std::size_t k = 0; k < v.x.size(); ++k) {
      points->SetPoint(pt, v.x[k], v.z[k], 0.0);
      connectivity->SetValue(conn++, pt++);
    }
    if (v.closed && !v.x.empty()) connectivity->SetValue(conn++, first);
    offsets->SetValue(b + 1, conn);
    open->SetValue(b, v.open ? 1 : 0);
    closed->SetValue(b, v.closed ? 1 : 0);
    index->SetValue(b, static_cast<int>(b));
    names->SetValue(b, v.name);
  }

  vtkNew<vtkCellArray> lines;
  lines->SetData(offsets, connectivity);
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(points);
  poly->SetLines(lines);
  vtkCellData* cd = poly->GetCellData();
  cd->AddArray(open);
  cd->AddArray(closed);
  cd->AddArray(index);
  poly->GetFieldData()->AddArray(names);
  write_polydata(path, poly, compression);
}

} // namespace demfem::dem::io
