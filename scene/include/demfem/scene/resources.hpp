// Estimates of what a scene needs before any work starts, against what the machine has: the
// memory available now, the continuum mesh a scene asks for (its cells and degrees of freedom,
// counted from the coarse grid the continuum builds, without deal.II), and the caps on particle
// files. The scene check (validate.cpp) refuses a scene whose estimate is above the available
// memory, with the estimate and the number it was compared with.
#pragma once

#include <cstddef>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "demfem/scene/scene.hpp"

namespace demfem::scene {

// The memory this process may still take [bytes] and where that number came from: the smaller of
// MemAvailable in /proc/meminfo and the room left under the cgroup's memory.max.
struct MemoryAvailable {
  double bytes = 0.0;
  std::string source; // e.g. "MemAvailable in /proc/meminfo"
};
// Nothing when neither can be read (not Linux): then no scene is refused for memory.
[[nodiscard]] std::optional<MemoryAvailable> available_memory();

// Graded coarse steps through every break (sorted), the continuum's grid with
// continuum.mesh_size_near: the cell size wanted at x is h(x) = min(h0, h_near + (g − 1)·d(x)), d
// the distance from [lo, hi], i.e. cells growing geometrically by g away from the focus
// (h_{k+1} = g h_k gives h = h_near + (g − 1)·distance). Per interval between breaks:
// n = ⌈∫ dx/h⌉ cells, placed at equal increments of ∫ dx/h.
[[nodiscard]] std::vector<double> graded_steps_through(const std::set<double>& breaks, double h0,
                                                       double h_near, double g, double lo,
                                                       double hi);
// The number of those steps, without listing them (for grids too large to list).
[[nodiscard]] std::size_t graded_cell_count(const std::set<double>& breaks, double h0,
                                            double h_near, double g, double lo, double hi);

// "1.23 GB" (decimal units).
[[nodiscard]] std::string format_bytes(double bytes);

// Continuum mesh of a scene (continuum/run/run.cpp build_problem): the coarse grid through every
// corner of the domain (below soil.continuum.surface) and of the structures, cells of
// min(W, H)/4 or graded from continuum.mesh_size_near (graded_steps_through), the cells
// whose centre lies in the soil or a structure meshed, then `refinement` global refinements.
// Degrees of freedom of FE_Q(degree)² on it: 2 (p² cells + p (Nx + Nz) + 1), exact for a
// rectangle of Nx × Nz cells.
struct ContinuumMeshEstimate {
  std::size_t columns = 0, rows = 0; // the coarse grid (before refinement)
  double coarse_cells = 0.0;         // meshed coarse cells
  double cells = 0.0;                // after refinement
  double dofs = 0.0;
  double bytes = 0.0; // kContinuumBaseBytes + dofs × kContinuumBytesPerDof
};
// Peak resident memory of a continuum run per degree of freedom, and its fixed part (deal.II,
// PETSc, MPI): the maximum resident set of cases/verification/continuum_footing_load.toml (Q2,
// implicit, direct solver, whose factorisation is the largest part; the explicit integrator's K0
// stage uses the same solver) at refinement 2, 3 and 4 (5,986, 23,490 and 93,058 dofs: 217, 290
// and 568 MB) lies within 4 % of 200 MB + 4096 B per dof.
inline constexpr double kContinuumBytesPerDof = 4096.0;
inline constexpr double kContinuumBaseBytes = 200e6;
[[nodiscard]] ContinuumMeshEstimate estimate_continuum_mesh(const Scene& scene);

// Particle files (soil.dem.particles_file): at most this many rows (soil.dem.count's ceiling).
inline constexpr std::size_t kMaxParticleFileRows = 100'000'000;

} // namespace demfem::scene
