// Internal to the DEM engine: the blocked pair kernel of the paper's law (cundall-rebound without
// tension). The pair loop runs in three passes over blocks of list entries:
//   1. gather (engine_forces.cpp): for kSize consecutive list entries, the pair (i, j), the entry,
//      x_i − x_j (computed for the touching test) and its history are written into the block, and
//      the block count advances only for a touching entry or one with history (branch-free
//      compaction);
//   2. kernel (this file, pair_kernel.cpp): geometry, kinematics and the law of a closed, already
//      active contact — the case of nearly every entry in a dense bed — reading the particle
//      arrays through i and j, without branches, so that the compiler vectorises it (AVX-512 or
//      AVX2 where the processor has it, chosen once at run time; SSE2 otherwise). An entry outside
//      that case
//      (first touch, the touch/release step of the spring, an ended contact, an overlap above
//      max_overlap) is marked kSlow;
//   3. scatter (engine_forces.cpp): in list order, the forces are added to the particles and the
//      histories written back; a kSlow entry is evaluated there by the scalar law
//      (contact::CundallRebound, its evaluate) on the geometry the one-pass loop computes
//      (pair_geometry).
// Every operation of the kernel that reaches a result is the scalar law's, in the same order and
// without contraction into fused multiply-adds, and the scatter adds in the scalar loop's order:
// results are bit-identical to the one-pass loop (test
// DemPairKernel.BlockedLoopBitIdenticalToScalar). Only the kernel's test of its case differs: it
// drops the law's two divisions of m* and A with a margin that leaves every doubtful entry to the
// scalar law (contact::detail::stays_closed).
#pragma once

#include <cstddef>
#include <cstdint>

namespace demfem::dem::detail {

// Scratch of one block of compacted list entries (structure of arrays). Not initialised: the
// gather writes entries 0 … m−1 before the kernel reads them.
struct PairBlock {
  static constexpr std::size_t kSize = 128;
  // inputs (gather): the history, and the pair's friction when the particles have several
  // materials; the kernel reads velocities, radii and masses through i and j
  alignas(64) double mus[kSize]; // friction of the pair
  alignas(64) double mud[kSize];
  alignas(64) double dx[kSize], dz[kSize];      // x_i − x_j, z_i − z_j [m]
  alignas(64) double ft[kSize];                 // history: shear spring force [N]
  alignas(64) std::int64_t fl[kSize];           // history flags
  alignas(64) std::uint64_t i[kSize], j[kSize]; // 64 bits: the kernel vectorises 4 entries at once
  std::uint32_t k[kSize];
  // results of an entry without kSlow (kernel)
  alignas(64) double fx[kSize], fz[kSize]; // force on i [N]
  alignas(64) double ti[kSize], tj[kSize]; // l_i f_t, l_j f_t [N·m]
  alignas(64) double fn[kSize], ft_new[kSize];
  alignas(64) double e_fric[kSize], e_n[kSize], e_s[kSize];
  // new history flags; kSlow set: not the kernel's case, the scalar law evaluates the entry
  alignas(64) std::int64_t fl_new[kSize];
  static constexpr std::int64_t kSlow = 1 << 8;
};

struct ReboundConstants {
  double kn, ks, dt;
  double max_overlap; // an entry above max_overlap·min(r_i, r_j) is left to the scalar path
  bool one_material;  // true: mus0, mud0 for every pair, the block's mus, mud are not read
  double mus0, mud0;
};

// The particle arrays the kernel reads (Particles' vectors).
struct ParticleArrays {
  const double *vx, *vz, *omega, *radius, *mass;
};

// The instruction set of the blocked passes, in increasing width.
enum class Isa { portable, avx2, avx512 };
// The widest the processor has (AVX-512 F, DQ and VL; AVX2; else portable), capped at `cap` (a
// benchmark and test switch).
Isa isa_up_to(Isa cap);

// Pass 2 over entries 0 … m−1 of the block, with the instruction set `isa` (from isa_up_to).
void rebound_kernel(const ReboundConstants& c, const ParticleArrays& p, PairBlock& b, std::size_t m,
                    Isa isa);

} // namespace demfem::dem::detail
