// Particle sets read from a file named in the scene (`soil.dem.particles_file`), for sets too
// large for an inline TOML list. Two formats, chosen by the file name's extension:
//
//   .csv  text (a leading UTF-8 byte-order mark is skipped): optional comment lines starting
//         with '#', blank lines, an optional header row
//         `x,z,r` or `x,z,r,vx,vz,omega`, then one particle per row with 3 or 6 numbers
//         (x, z, r [, vx, vz, ω]) in SI units, r > 0. Every row has the same number of fields.
//   .npy  NumPy array file (format 1.0–3.0), little-endian float64 ('<f8'), C order, shape
//         (N, 3) or (N, 6), columns as above.
//
// Errors are located: CSV problems at file:line:column, .npy problems at the file and the byte
// offset (and row) in their message.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "demfem/scene/load.hpp"
#include "demfem/scene/resources.hpp"

namespace demfem::scene {

using ParticleRow = std::array<double, 6>; // x, z, r, vx, vz, ω

// What a particle file may hold: at most max_rows rows, and rows × kBytesPerParticle (what the
// DEM will hold per particle, validate.hpp) within the memory available, checked before the rows
// are read (.npy: from its header, against the file's size) or as they are read (.csv).
struct ParticleFileLimits {
  std::size_t max_rows = kMaxParticleFileRows;
  std::optional<double> memory_bytes; // unset: the machine's available memory (resources.hpp)
  std::string memory_source;          // where memory_bytes came from, for messages
};

// Reads the file, streaming it (memory grows with the rows, not the file); appends every problem
// found (at most `max_errors` of them, then one line saying how many more) to diags and returns
// the rows when there was none (else nothing). `key` names the scene key in the diagnostics (e.g.
// "soil.dem.particles_file"). Zero rows is a problem: zero particles cannot be run.
std::vector<ParticleRow> read_particles_file(const std::filesystem::path& path,
                                             const std::string& key, std::vector<Diagnostic>& diags,
                                             std::size_t max_errors = 20,
                                             const ParticleFileLimits& limits = {});

// Writes rows as .csv (header x,z,r,vx,vz,omega, 17 significant digits: reads back exactly) or
// .npy (by extension). Throws std::runtime_error when the file cannot be written.
void write_particles_file(const std::filesystem::path& path, const std::vector<ParticleRow>& rows);

} // namespace demfem::scene
