// Coarse-graining: DEM particle data → continuum-like fields on a regular grid,
// with the kernel averaging of Goldhirsch (2010) and Weinhart et al. (2012):
//   density   ρ(x)   = Σ_i m_i φ(x − x_i)
//   momentum  p(x)   = Σ_i m_i v_i φ(x − x_i)
//   stress    σ(x)   = Σ_c f_ij ⊗ (x_j − x_i) ∫_0^1 φ(x − x_i − s(x_j − x_i)) ds
//                      − Σ_i m_i v'_i ⊗ v'_i φ(x − x_i)          (tension positive)
// with f_ij the contact force on i from j and v'_i = v_i − p/ρ the fluctuation velocity.
// Displacement and its gradient: kernel-weighted least-squares affine fit of the particle
// displacements, u(x_i) ≈ a + G (x_i − x), weights m_i φ(x − x_i) — exact for linear fields.
// The kernel is Lucy's (1977) 2D polynomial with support radius c (the stated "width"):
//   φ(r) = 5/(π c²) (1 + 3r/c)(1 − r/c)³ for r < c, 0 beyond; ∫ φ dA = 1.
// Plane strain, per metre of thickness: masses in kg/m, forces in N/m, stresses in Pa.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace demfem::compare {

// ---- kernel and grid ----------------------------------------------------------------------------
[[nodiscard]] double lucy_kernel(double r, double c);

struct Grid {
  double x0 = 0, z0 = 0, h = 1; // lower-left node and spacing [m]
  int nx = 1, nz = 1;           // nodes
  [[nodiscard]] double x(int i) const { return x0 + h * i; }
  [[nodiscard]] double z(int k) const { return z0 + h * k; }
  [[nodiscard]] std::size_t size() const { return static_cast<std::size_t>(nx) * nz; }
  [[nodiscard]] std::size_t at(int i, int k) const { return static_cast<std::size_t>(k) * nx + i; }
};

struct CgParticles {
  std::vector<double> x, z, mass, vx, vz; // positions [m], masses [kg/m], velocities [m/s]
  std::vector<double> ux, uz;             // displacements from a reference state [m] (optional)
};

struct CgContact {
  double xi = 0, zi = 0, xj = 0, zj = 0; // centres of the two particles (or i's contact point)
  double fx = 0, fz = 0;                 // force on i from j [N/m]
  bool boundary = false;                 // j is a wall or structure: (xj, zj) is the contact point
};

struct CgFields {
  Grid grid;
  double width = 0;                                 // kernel support radius c [m]
  std::vector<double> density, px, pz;              // ρ, momentum
  std::vector<double> sxx, szz, sxz;                // stress (tension positive), symmetric part
  std::vector<double> ux, uz;                       // displacement (affine fit at the node)
  std::vector<double> exx, ezz, exz, vol, rotation; // small strain, ε_vol, ½(∂u_z/∂x − ∂u_x/∂z)
};

// Fields on `grid` with Lucy support radius `width`. Displacement fields only when the
// particles carry ux/uz; stress only from `contacts`. A node with fewer than 3 particles in reach
// (no affine fit) gets NaN displacement/strain; density 0 marks nodes outside the material.
[[nodiscard]] CgFields coarse_grain(const CgParticles& p, const std::vector<CgContact>& contacts,
                                    const Grid& grid, double width);

// ---- reading the solvers' snapshots ---------------------------------------------------------
struct PvdEntry {
  double time = 0.0;
  std::filesystem::path file; // absolute or relative to the caller's cwd
};
// Entries of a ParaView .pvd collection, in time order (empty when missing or unreadable).
[[nodiscard]] std::vector<PvdEntry> read_pvd_entries(const std::filesystem::path& pvd);
// The index of the entry whose time is nearest to t (0 for an empty collection).
[[nodiscard]] std::size_t nearest_entry(const std::vector<PvdEntry>& entries, double t);

struct ParticleSnapshot {
  std::vector<std::uint32_t> id;
  std::vector<double> x, z, radius, vx, vz;
};
[[nodiscard]] ParticleSnapshot read_particles_vtp(const std::filesystem::path& vtp);

// Force chains .vtp (dem/src/io/vtk.cpp): a line from particle i to particle j, or from particle
// i to its contact point on a wall or structure (cell array `boundary` ≥ 0), with the normal
// force fn (compression positive) and the shear force fs of the contact law (paper eq. 2.15:
// force on i = fn·n + fs·t, n = (x_i − x_j)/|x_i − x_j|, t = (−n_z, n_x); for a boundary contact
// x_j is the contact point, so the stress gets Weinhart et al.'s (2012) boundary term, the line
// integral from the particle's centre to its contact point). Files written before the boundary
// lines existed give particle pairs only.
[[nodiscard]] std::vector<CgContact> read_force_chains_vtp(const std::filesystem::path& vtp);

// A continuum .pvtu/.vtu snapshot (continuum/fem/output.cpp Model::write_vtu): points (reference
// coordinates) with their data — "displacement_x", "displacement_z", "stress_xx", "stress_zz",
// "stress_xz", "volumetric_strain", "material", … (deal.II writes its cell data per patch point, so
// every array is per point) — and cells as point ids in VTK order.
struct ContinuumSnapshot {
  std::vector<double> x, z;
  std::vector<std::vector<std::size_t>> cells;
  std::map<std::string, std::vector<double>> data; // per point
  [[nodiscard]] const std::vector<double>* get(const std::string& name) const;
};
[[nodiscard]] ContinuumSnapshot read_continuum_vtu(const std::filesystem::path& file);

// Ground elevation at the centres of `bins` equal x bins over [x0, x1]: along the top boundary of
// the soil cells (material 0; the highest reference z at each x) moved by its vertical
// displacement, interpolated linearly in x. NaN outside the soil's x range.
[[nodiscard]] std::vector<double> continuum_surface(const ContinuumSnapshot& s, double x0,
                                                    double x1, int bins);

// Settlement of the DEM's surface followed as material, as continuum_surface follows the soil's
// top nodes: per bin of x over [x0, x1] (by the particle's x in `rest`), the mean of
// z_rest − z_end over the particles of `rest` whose top (z + r) is within one mean particle
// diameter of the bin's highest top, each found by id in `end`. NaN for a bin with none. The top
// of the bed per bin (the surface probe) jumps by a grain whenever another particle becomes the
// highest; the particles themselves move smoothly.
[[nodiscard]] std::vector<double> dem_surface_settlement(const ParticleSnapshot& rest,
                                                         const ParticleSnapshot& end, double x0,
                                                         double x1, int bins);

// How far a snapshot's soil cells (material 0) are from the small strains the continuum's
// kinematics assume: the share of the soil's area whose |volumetric_strain| or plastic_strain
// (cell values) exceeds `limit`, and the largest of each with its cell's centre. Cells without
// those arrays count as within.
struct StrainRange {
  double area = 0.0, area_beyond = 0.0;                  // [m²]
  double max_volumetric = 0.0, vol_x = 0.0, vol_z = 0.0; // largest |ε_v| (signed value), where
  double max_plastic = 0.0, plastic_x = 0.0, plastic_z = 0.0;
  [[nodiscard]] double share_beyond() const { return area > 0.0 ? area_beyond / area : 0.0; }
};
[[nodiscard]] StrainRange continuum_strain_range(const ContinuumSnapshot& s, double limit);
// The strain up to which the report takes the continuum's small-strain kinematics as valid.
inline constexpr double kSmallStrainLimit = 0.1;

// The continuum's point array `name` at the grid nodes: bilinear inside the soil cell (material 0)
// that holds the node (the mesh is a tensor-product grid of axis-parallel rectangles); NaN outside
// the soil.
[[nodiscard]] std::vector<double> sample_continuum(const ContinuumSnapshot& s, const Grid& grid,
                                                   const std::string& name);

// ---- the report's field comparison ------------------------------------------------------------
struct FieldComparison {
  std::vector<std::string> figures; // PNGs relative to the run directory
  std::vector<std::string> notes;   // what was compared, and problems
  double width = 0.0, rest_time = 0.0, end_time = 0.0;
  struct Summary {
    std::string field;
    double mean_dem = 0, mean_continuum = 0, rms_difference = 0;
  };
  std::vector<Summary> summaries;
};
// Coarse-grains the DEM snapshots nearest to `rest_time` and to the end of the run on a regular
// grid over the domain box, samples the continuum snapshots at the same times, and draws vertical
// stress (at the end), horizontal displacement and volumetric strain (end − rest) side by side
// with their difference. Writes <run>/compare/fields_*.png and fields.csv. `width` ≤ 0: 2 mean
// particle diameters.
[[nodiscard]] FieldComparison compare_fields(const std::filesystem::path& run_dir, double rest_time,
                                             double density, double width = 0.0);

} // namespace demfem::compare
