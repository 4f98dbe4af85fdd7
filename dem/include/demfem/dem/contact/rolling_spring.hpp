// Rolling sub-model `elastic-plastic`: rolling resistance by an elastic–plastic rolling spring
// (Iwashita & Oda 1998, J. Eng. Mech. 124:285; Jiang, Yu & Harris 2005, Comput. Geotech. 32:340;
// the "type C" model of Ai, Chen, Rotter & Ooi 2011, Powder Technol. 206:269, without its
// dashpot). A moment on each contact opposes the relative rolling of the two bodies:
//   m_r ← m_r − k_r ω_r Δt,  |m_r| ≤ μ_r R* f_n,  k_r = K_r R*²
// with ω_r = ω_i − ω_j (contact.hpp), R* the contact's effective radius (r_i against a wall or a
// structure) and f_n its normal force. K_r is a stiffness per unit rolling displacement R*θ, as
// LAMMPS's `rolling sds` k_roll. The moment acts on i and its opposite on j: a couple, so momentum
// and angular momentum are conserved. At the cap the spring slides like the Coulomb slider of the
// shear spring (coulomb.hpp): sliding on, the plastic rotation times the moment is dissipated;
// sticking to sliding, the spring energy above the cap is released at once; without compression
// the spring's energy is lost. The spring energy m_r²/(2k_r) is counted with the shear springs'.
// A disk on a slope stays put while tan θ ≤ μ_r (the rolling moment's cap μ_r r m g cos θ
// against gravity's moment m g r sin θ about the contact point), and rolls down at
// a = g (sin θ − μ_r cos θ)/(1 + I/(m r²)) above it (test DemRolling.*).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "demfem/dem/contact/contact.hpp"
#include "demfem/scene/params.hpp"

namespace demfem::dem::contact {

struct RollingSpring {
  struct Params {
    static constexpr const char* kName = "rolling-spring";
    double rolling_stiffness = 3.0e5; // K_r [N/m]
    double mu_rolling = 0.1;          // μ_r
    void fields(scene::ParamVisitor& v) {
      v.number({"rolling_stiffness", "K_r", "N/m",
                "rolling = \"elastic-plastic\": stiffness of the rolling spring per unit rolling "
                "displacement R*θ (as LAMMPS's k_roll); the moment grows by K_r R*² per radian "
                "of relative rotation until μ_r R* f_n",
                scene::Scale::stiffness},
               rolling_stiffness, scene::positive());
      v.number({"mu_rolling", "μ_r", "",
                "rolling = \"elastic-plastic\": coefficient of rolling friction; the rolling "
                "moment is capped at μ_r R* f_n (R*: the contact's effective radius), so a disk "
                "on a slope steeper than atan μ_r rolls"},
               mu_rolling, scene::non_negative());
    }
  } p;

  static constexpr const char* name = "elastic-plastic";
  static constexpr const char* summary =
      "an elastic–plastic rolling spring K_r R*² with its moment capped at μ_r R* f_n (Iwashita "
      "& Oda 1998; Jiang et al. 2005)";
  static constexpr bool kActive = true;
  static constexpr std::size_t kHistory = 1; // the rolling moment m_r on the owner [N·m]
  static std::vector<scene::ParamBlock> blocks() { return {scene::ParamBlock(Params{})}; }
  static RollingSpring from(const scene::ModelChoice& c) { return {c.get<Params>()}; }

  [[nodiscard]] double stiffness(const ContactInput& in) const {
    return p.rolling_stiffness * in.r_eff * in.r_eff; // k_r = K_r R*²
  }
  // After the law: m_r of this step into r.mr, its energies into r.
  void evaluate(const ContactInput& in, ContactHistory& h, double* extra, ContactResult& r) const {
    const double kr = stiffness(in);
    const double trial = extra[0] - kr * in.wr * in.dt; // the elastic increment
    const double cap = p.mu_rolling * in.r_eff * r.fn;
    double m = trial;
    if (!(cap > 0.0)) { // no compression: no rolling moment, the spring's energy is lost
      r.e_friction += 0.5 * trial * trial / kr;
      h.flags = static_cast<std::uint8_t>(h.flags & ~kHistRolling);
      m = 0.0;
    } else if (std::abs(trial) > cap) {
      m = std::copysign(cap, trial);
      r.e_friction += (h.flags & kHistRolling) ? std::abs(m * (trial - m)) / kr
                                               : 0.5 * (trial * trial - m * m) / kr;
      h.flags = static_cast<std::uint8_t>(h.flags | kHistRolling);
    } else {
      h.flags = static_cast<std::uint8_t>(h.flags & ~kHistRolling);
    }
    extra[0] = m;
    r.mr = m;
    r.e_shear += 0.5 * m * m / kr;
  }
  // The contact ended: the spring's remaining energy counts as dissipated.
  void release(const ContactInput& in, ContactHistory& /*h*/, double* extra,
               ContactResult& r) const {
    if (extra[0] != 0.0) r.e_friction += 0.5 * extra[0] * extra[0] / stiffness(in);
    extra[0] = 0.0;
  }
  // The rolling spring of two of the smallest particles, R* = r_min/2.
  void add_step(StepStiffness& s, double r_min, double /*m_min*/) const {
    s.kr = p.rolling_stiffness * 0.25 * r_min * r_min;
  }
  // The moment on the owner is the opposite of the moment on the partner (and ω_r changes sign
  // with the owner): the new owner's moment is −m_r.
  static void flip_owner(double* extra) { extra[0] = -extra[0]; }
};

} // namespace demfem::dem::contact
