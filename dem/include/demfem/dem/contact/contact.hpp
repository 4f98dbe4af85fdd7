// What every contact law and sub-model of the DEM shares: the sign convention, the per-contact
// history, the input of one contact in one step and its result. A law is composed of sub-models
// (law.hpp: normal, damping, tangential; rolling on top), each in its own header of this folder
// with its parameter block (scene/params.hpp), its part of the stable step and its part of the
// evaluation; registry.hpp lists them. No I/O, no allocation.
//
// ---- Sign convention (the one used everywhere in dem/) ------------------------------------------
// Coordinates x right, z up. Rotations and moments counter-clockwise positive.
// For a contact between i and j (j may be a boundary):
//   n = (x_i − x_j)/|x_i − x_j|   unit normal pointing from j to i (for a boundary: from the
//                                 closest boundary point to the centre of i)
//   t = (−n_z, n_x)               n rotated counter-clockwise by 90°
//   δ = r_i + r_j − |x_i − x_j|   overlap, > 0 when touching (paper eq. 2.3)
//   contact point: the middle of the overlap, at arm l_i = r_i − δ/2 from i and l_j = r_j − δ/2
//   from j (boundary: on the boundary surface, l_i = r_i − δ). With this choice the pair
//   torques balance the moment of the pair forces exactly, so angular momentum is conserved.
//   Relative velocity of i's contact point w.r.t. j's:  v_rel = v_i − v_j − (l_i ω_i + l_j ω_j) t
//   v_n = −v_rel·n   normal approach speed (approach positive, paper eq. 2.5)
//   v_s =  v_rel·t   slip speed
//   ω_r = ω_i − ω_j  relative rolling rate (ω_j of a wall 0, of a structure its rotation rate)
// The law returns f_n (compression positive), f_t and a rolling moment m_r; the force on i is
// F = f_n n + f_t t, on j it is −F; the moments are M_i = −l_i f_t + m_r and M_j = −l_j f_t − m_r
// (paper eq. 2.15 up to the arm; m_r is a couple, so angular momentum stays conserved). Shear
// springs are updated as f_t ← f_t − k_s v_s Δt, i.e. they oppose slip; the power f_t v_s of the
// shear force equals minus the rate of the spring energy f_t²/(2 k_s). Rolling springs likewise:
// m_r ← m_r − k_r ω_r Δt.
#pragma once

#include <cstdint>

namespace demfem::dem {

enum ContactHistoryFlag : std::uint8_t {
  kHistActive = 1u << 0,  // the pair has touched (history exists)
  kHistSliding = 1u << 1, // Coulomb limit reached: dynamic friction applies
  kHistBonded = 1u << 2,  // tension option: the contact may carry tension
  kHistRolling = 1u << 3, // rolling limit reached: the rolling moment is at its cap
};

// Persistent per-pair state, kept across neighbour rebuilds. A sub-model that needs more per
// contact declares kHistory extra values (e.g. the rolling spring's moment); the engine keeps
// them beside this, across rebuilds and checkpoints, and passes them to evaluate().
struct ContactHistory {
  double ft = 0.0;        // shear spring force e_s [N]
  float fn = 0.0f;        // last normal force (output, energy) [N]
  std::uint8_t flags = 0; // ContactHistoryFlag
};

// Geometry and kinematics of one contact in one step.
struct ContactInput {
  double delta; // overlap [m]
  double vn;    // approach speed [m/s]
  double vs;    // slip speed [m/s]
  double m_eff; // m_i m_j/(m_i + m_j), or m_i against a boundary [kg]
  double r_eff; // r_i r_j/(r_i + r_j), or r_i against a boundary [m]
  double mu_s;  // static friction
  double mu_d;  // dynamic friction
  double dt;    // [s]
  double wr;    // relative rolling rate ω_i − ω_j [rad/s]
};

struct ContactResult {
  double fn = 0.0; // normal force incl. dashpot, compression positive [N]
  double ft = 0.0; // shear force [N]
  double mr = 0.0; // rolling moment on i (on j: −mr) [N·m]
  // Rebound at first touch (cundall-rebound): the contact's approach speed v_n and the approach
  // its impulse leaves, K v_n. The engine applies the impulses after the pair loop, contact by
  // contact (Engine::apply_rebounds), so that contacts of one particle that first touch in the
  // same step share one collision; it books the energy. rebound_vn = 0: no rebound.
  double rebound_vn = 0.0, rebound_to = 0.0; // [m/s]
  double e_friction = 0.0;                   // energy dissipated by friction in this step [J]
  double e_damping = 0.0;                    // energy dissipated by dashpots in this step [J]
  double e_normal = 0.0;                     // normal spring energy after the step [J]
  double e_shear = 0.0;                      // shear (and rolling) spring energy after the step [J]
  bool touching = false;                     // false: the history was reset (contact ended)
};

// What the stable time step needs from a law (stable_step.cpp): the stiffnesses of one contact
// between two of the smallest particles (radius r_min, pair mass m* = m_min/2), the damping
// ratio ξ of that contact's dashpots, and the rolling spring's moment stiffness k_r [N·m/rad].
struct StepStiffness {
  double kn = 0.0, ks = 0.0, xi = 0.0, kr = 0.0;
};

// The overlap at which laws whose stiffness grows with it (Hertz) are given a stiffness for the
// stable step and for global damping: 5 % of the radius r of the particles in question (two of
// them: R* = r/2).
inline constexpr double kReferenceOverlap = 0.05;

} // namespace demfem::dem
