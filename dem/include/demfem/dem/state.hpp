// DEM state as plain structure-of-arrays data. Kernels read and write these arrays; I/O code
// (VTK, CSV, checkpoints) reads them. No behaviour lives here.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace demfem::dem {

// Particle flags (bit set).
enum ParticleFlag : std::uint32_t {
  kFlagNone = 0,
  kFlagRemoved = 1u << 0, // fell out through an opened wall; no longer integrated
  kFlagTagged = 1u << 1,  // traced by a loci probe
  // removed while no wall was open: it left through a gap the scene did not plan
  kFlagLeftUnplanned = 1u << 2,
};

// Disks of unit-thickness mass m = ρπr²·t, inertia I = ½mr² (PFC2D convention, paper.md §1).
struct Particles {
  std::vector<double> x, z;            // centre [m]
  std::vector<double> phi;             // rotation, counter-clockwise positive [rad]
  std::vector<double> vx, vz;          // velocity [m/s]
  std::vector<double> omega;           // angular velocity, counter-clockwise positive [rad/s]
  std::vector<double> fx, fz;          // resultant force of the current step [N]
  std::vector<double> torque;          // resultant moment, counter-clockwise positive [N·m]
  std::vector<double> radius;          // [m]
  std::vector<double> mass;            // [kg]
  std::vector<double> inv_mass;        // 1/m [1/kg]
  std::vector<double> inv_inertia;     // 1/I [1/(kg·m²)]
  std::vector<std::uint32_t> id;       // stable id (survives reordering)
  std::vector<std::uint16_t> material; // index into the friction table (events change it)
  std::vector<std::uint32_t> flags;

  [[nodiscard]] std::size_t size() const { return x.size(); }
};

// One contact as seen by output code (force chains): particle–particle (j ≥ 0) or
// particle–boundary (j < 0, boundary index −1 − j).
struct ContactView {
  std::uint32_t i = 0;
  std::int64_t j = 0;
  double cx = 0.0, cz = 0.0; // contact point [m]
  double fn = 0.0;           // normal force, compression positive [N]
  double fs = 0.0;           // shear force [N]
  bool tensile = false;      // fn < 0 (tension option on)
};

// A boundary outline for output: line walls, polylines and rigid structure outlines.
struct BoundaryView {
  std::string name;
  std::vector<double> x, z; // vertices in order
  bool closed = false;      // rigid structures are closed polygons
  bool open = false;        // an opened wall segment (no longer acts)
};

} // namespace demfem::dem
