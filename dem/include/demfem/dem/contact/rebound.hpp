// Damping sub-model `rebound`, the paper's (§2.1.2 iv, read as Newton restitution, see paper.md
// §1): a contact whose normal approach speed at first touch exceeds V_0 receives, in that step, a
// normal impulse P = m*(1 − K) v_n along the line of centres, equal and opposite on the two
// bodies. The approach speed drops to K v_n, the elastic spring then returns it unchanged, so the
// pair separates at K times its approach speed. Momentum and angular momentum are conserved (the
// impulse acts along the line of centres); absolute velocities are never rescaled. The energy
// ½ m* v_n² (1 − K²) is booked as rebound dissipation. Slower contacts stay elastic.
// Contacts of a particle that first touch in the same step (a disk landing on two disks, or on
// two walls at once) are one collision: the engine applies their impulses one after the other,
// each seeing the approach the earlier ones left, P = m* max(0, w − K v_n) with w the current
// approach (sequential impulses, Engine::apply_rebounds), so no contact's approach is driven
// below K times its own and the loss is booked once. The sub-model reports v_n and K v_n only.
// Friction cap (a modelling choice): the Coulomb limit μ f_n (eq. 2.13) sees the spring force f_n
// only, not the rebound impulse P/Δt, so the impulse carries no tangential part. The spring then
// sees the reduced approach speed K v_n, and the friction acting over the contact is that of the
// gentle elastic rebound: a disk hitting a floor at 2 m/s normal and 1 m/s tangential (μ = 0.5,
// K = 0.1) keeps 0.80 of its tangential speed (test DemStability.FrictionCapSees…), where Newton
// restitution with Coulomb friction on the impulse (|P_t| ≤ μ P_n) would keep at most 2/3 (it
// reaches the disk's rolling limit v_t' = (2/3) v_t). Oblique impacts above V_0 thus lose less
// tangential momentum than in impulse-based codes.
#pragma once

#include <cstdint>
#include <vector>

#include "demfem/dem/contact/contact.hpp"
#include "demfem/scene/params.hpp"

namespace demfem::dem::contact {

struct Rebound {
  struct Params {
    static constexpr const char* kName = "rebound";
    double rebound = 0.1;       // K
    double rebound_speed = 1.0; // V_0 [m/s]
    void fields(scene::ParamVisitor& v) {
      v.number({"rebound", "rebound K", "",
                "cundall-rebound: a contact that first touches faster than rebound_speed "
                "separates at K times its approach speed (Newton restitution; paper §2.1.2 iv)"},
               rebound, scene::in_range(0.0, 1.0));
      v.number({"rebound_speed", "V_0", "m/s",
                "cundall-rebound: the approach speed V_0 above which the rebound rule acts; "
                "slower contacts are elastic"},
               rebound_speed, scene::non_negative());
    }
  } p;

  static constexpr bool kDashpot = false;
  static std::vector<scene::ParamBlock> blocks() { return {scene::ParamBlock(Params{})}; }
  static Rebound from(const scene::ModelChoice& c) { return {c.get<Params>()}; }

  // Newton restitution at first touch (the engine applies the impulse); the spring sees the
  // approach after the impulse.
  void on_first_touch(const ContactInput& in, ContactResult& r, double& vn_spring) const {
    if (in.vn > p.rebound_speed) {
      r.rebound_vn = in.vn;
      r.rebound_to = p.rebound * in.vn;
      vn_spring = r.rebound_to;
    }
  }
  template <class N> [[nodiscard]] double normal(double en, const ContactInput&, const N&) const {
    return en;
  }
  // The rebound impulse acts once per collision, not as a dashpot: ξ = 0.
  [[nodiscard]] double step_xi(double /*kn*/, double /*ks*/, double /*m_star*/) const {
    return 0.0;
  }
};

} // namespace demfem::dem::contact
