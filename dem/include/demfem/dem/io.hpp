// DEM output and restart I/O: VTK XML PolyData snapshots (particles, force chains, boundaries),
// ParaView .pvd collections and versioned binary checkpoints. The engine calls these from its
// output schedule, never from inside a kernel. CSV time series live in demfem/output/csv.hpp
// (shared with the continuum solver).
//
// Coordinates: the DEM plane is (x, z) with z up. VTK files place a particle at the 3D point
// (x, z, 0), so ParaView shows the model in its XY plane with z as the screen's vertical axis;
// vectors follow the same map: velocity (vx, vz, 0), force (fx, fz, 0).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "demfem/dem/state.hpp"
#include "demfem/scene/scene.hpp"

namespace demfem::dem::io {

// Any failure of this layer (cannot write, malformed input, bad checkpoint) carries the path.
class IoError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

// "stem_000123.ext": zero-padded (6 digits, more when needed) series file names.
[[nodiscard]] std::string numbered_file_name(const std::string& stem, long long index,
                                             const std::string& extension);

// ---- VTK XML PolyData (.vtp): binary, appended raw data, UInt64 headers ----
// Compressed as `compression` says: zlib (level 1) unless given (the packing's .vtp); a run passes
// its [output] vtk_compression (lz4 by default; scene.hpp). Each file is written to "<path>.tmp"
// and renamed over <path>, so a reader never sees a half-written snapshot.

// One vertex per particle not flagged kFlagRemoved, at (x, z, 0). Point data:
//   id (UInt32), radius, diameter (Float64), velocity (3 comp.), angular_velocity (omega,
//   counter-clockwise positive), rotation (phi), force (3 comp.), material (UInt16),
//   speed (|v|).
void write_particles_vtp(const std::filesystem::path& path, const Particles& particles,
                         scene::VtkCompression compression = scene::VtkCompression::Zlib);

// One line cell per contact: a particle pair (j ≥ 0) between the two particle centres, a
// particle–boundary contact (j < 0) from the particle's centre to its contact point (cx, cz) on
// the boundary. i and j index the Particles arrays. Cell data: normal_force, shear_force
// (Float64), tensile (UInt8 0/1), boundary (Int32: −1 for a pair, else the boundary's index in
// the order of the boundaries file, −1 − j). Throws IoError for an index out of range.
void write_force_chains_vtp(const std::filesystem::path& path, const Particles& particles,
                            std::span<const ContactView> contacts,
                            scene::VtkCompression compression = scene::VtkCompression::Zlib);

// One polyline cell per boundary through its vertices at (x, z, 0); a closed outline repeats its
// first vertex at the end. Cell data: open (UInt8 0/1), closed (UInt8 0/1), boundary_index
// (Int32, position in `boundaries`). Field data: names (String, one per boundary). Throws
// IoError when x and z differ in length.
void write_boundaries_vtp(const std::filesystem::path& path,
                          std::span<const BoundaryView> boundaries,
                          scene::VtkCompression compression = scene::VtkCompression::Zlib);

// ---- ParaView collection (.pvd) ----
// One series (e.g. particles over time). Every add() rewrites the whole .pvd atomically
// (temporary file, fsync, rename), so after a crash the collection on disk is valid and lists
// every snapshot added before it.
class PvdCollection {
public:
  struct Entry {
    double time = 0.0;
    std::string file; // as written into the .pvd: relative to the .pvd's directory when possible
  };

  // Starts an empty collection at `path` (an existing file is replaced at the first write).
  explicit PvdCollection(std::filesystem::path path);

  // Reopens a collection written by this class for a resumed run: keeps the entries with
  // time ≤ max_time and rewrites the file. A missing file gives an empty collection; a file
  // that cannot be parsed throws IoError.
  static PvdCollection resume(std::filesystem::path path, double max_time);

  // Adds a snapshot and rewrites the .pvd. `file` is stored relative to the .pvd's directory
  // when it lies beneath it (lexically), otherwise as given.
  void add(double time, const std::filesystem::path& file);

  [[nodiscard]] const std::vector<Entry>& entries() const { return entries_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

private:
  void rewrite() const;

  std::filesystem::path path_;
  std::vector<Entry> entries_;
};

// ---- Checkpoints ----
// Binary, native byte order (checked through a marker on read), layout of format version 1:
//   "DEMFEMCK" | u32 version | u32 0x01020304 | u64 particle count | f64 time | i64 step |
//   f64 dt | u32 label length + bytes | u32 array count | per array: char[16] name, u32 element
//   size, u32 0, u64 element count | array data in table order | u64 extra size + bytes |
//   u64 FNV-1a 64 of every preceding byte.
// Written to "<path>.tmp", fsynced, renamed over <path>, then the directory is fsynced.

inline constexpr std::uint32_t kCheckpointFormatVersion = 1;

struct CheckpointMeta {
  double time = 0.0;     // simulated time [s]
  std::int64_t step = 0; // steps taken
  double dt = 0.0;       // time step in use [s]
  std::string label;     // free text, e.g. scene label / digest so a resume can refuse a mismatch
};

struct Checkpoint {
  Particles particles;
  CheckpointMeta meta;
  std::vector<std::byte> extra; // opaque engine state (contact history, structures, …)
};

// Throws IoError when the Particles arrays differ in length or the file cannot be written.
void write_checkpoint(const std::filesystem::path& path, const Particles& particles,
                      const CheckpointMeta& meta, std::span<const std::byte> extra = {});

// Throws IoError naming the path and the cause: missing file, not a checkpoint (bad magic),
// unsupported format version, other byte order, truncated, checksum mismatch, malformed table.
[[nodiscard]] Checkpoint read_checkpoint(const std::filesystem::path& path);

} // namespace demfem::dem::io
