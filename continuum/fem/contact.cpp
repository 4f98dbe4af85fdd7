// Coulomb contact of the explicit integrator (Problem::contacts): kinematic node-on-plane contact
// with the soil at rest in the shaking frame or on a moving rigid body, solved with the nodes'
// trial accelerations at every central-difference step; the contact forces a model reports, in
// the explicit run or from the implicit stages' reactions before it.
#include "impl.hpp"

namespace demfem::continuum::fem {

using namespace explicit_detail;

// A contact record of a node on a plane: its dofs, outward normal and position, no force yet.
Explicit::Contact Explicit::contact_at(const Core::ContactNode& n, std::size_t plane) {
  Contact c;
  c.ix = n.ix;
  c.iz = n.iz;
  c.nx = n.nx;
  c.nz = n.nz;
  c.x = n.X[0];
  c.z = n.X[1];
  c.plane = plane;
  return c;
}

// Coulomb contact nodes: every soil node on a contact plane's faces, unless one of its dofs is
// held otherwise (a rigid body, a prescribed or periodic dof, or fixed by a box boundary
// condition of a face off the planes, e.g. the corner with a fixed base): such a node keeps
// those constraints and takes no contact force.
void Explicit::contact_setup() {
  const Problem& pb = core.pb;
  State& e = state;
  e.contacts.clear();
  e.contact_work.assign(pb.contacts.size(), 0.0);
  const auto nodes = core.contact_nodes();
  std::vector<int> body_of(pb.regions.size(), -1); // region → its moving contact body
  for (std::size_t bi = 0; bi < e.bodies.size(); ++bi) {
    e.bodies[bi].contacts.clear();
    if (e.bodies[bi].contact) body_of[e.bodies[bi].region] = static_cast<int>(bi);
  }
  std::set<std::pair<int, types::global_dof_index>> on_body; // (body, node): one record each
  for (std::size_t k = 0; k < nodes.size(); ++k)
    for (const ContactNode& c : nodes[k]) {
      bool held = false, rigid_or_linked = false;
      for (const auto i : {c.ix, c.iz}) {
        held = held || (e.kind[i] != 0 && !(e.kind[i] == 1 && core.contact_roller[i]));
        rigid_or_linked = rigid_or_linked || e.kind[i] >= 2;
      }
      if (rigid_or_linked) continue; // its force belongs to a rigid body, a patch or a master
      Contact ct = contact_at(c, k);
      ct.held = held;
      const int region = pb.contacts[k].region;
      if (region >= 0 && body_of[region] >= 0 && !held) {
        // a node at a corner of the body (on two of its faces) keeps the first face's contact
        // only: one normal per node keeps the body's coupled system regular
        if (!on_body.insert({body_of[region], c.ix}).second) continue;
        ct.body = body_of[region];
        e.bodies[ct.body].contacts.push_back(e.contacts.size());
      }
      e.contacts.push_back(ct);
    }
  for (const auto& c : e.contacts)
    if (!c.held) e.kind[c.ix] = e.kind[c.iz] = 0;
}

// Kinematic node-on-plane contact with Coulomb friction for explicit central differences
// (forward-increment Lagrange multipliers, Carpenter, Taylor & Katona 1991; Belytschko, Liu &
// Moran 2000 §10.4): from the trial acceleration a* = f/m of each contact node, the normal force
// N = m (g + Δt v_n + Δt τ a*_n)/(Δt τ) puts the node back on the plane at the next step
// (g = u·n, penetration positive); N ≤ 0 means the node leaves the plane (no force). The stick
// force F = −m (v_t/τ + a*_t) stops its tangential motion at the next velocity; Coulomb: it
// sticks when |F| ≤ μ_s N, otherwise it slides under μ_d N against the trial tangential motion
// (sign F). τ is the time to the next velocity (Δt, or Δt/2 at the initial acceleration).
void Explicit::apply_contacts() {
  State& e = state;
  const double dt = e.contact_dt, tau = e.contact_tau;
  for (auto& c : e.contacts) {
    if (c.body >= 0 && !c.held) continue; // with its body (contact_body)
    c.fx = c.fz = c.N = c.Ft = 0.0;
    c.slide = false;
    if (c.held) { // the normal part of the reaction −f that holds the fixed dof at rest
      const types::global_dof_index i = std::abs(c.nx) > 0.5 ? c.ix : c.iz;
      if (e.kind[i] != 1) continue;
      const double r = -e.f[i];
      (i == c.ix ? c.fx : c.fz) = r;
      c.N = std::max(0.0, -(c.fx * c.nx + c.fz * c.nz));
      continue;
    }
    if (dt <= 0 || tau <= 0) continue;
    const double m = e.mass[c.ix];
    const double tx = -c.nz, tz = c.nx;
    const double g = c.nx * e.u[c.ix] + c.nz * e.u[c.iz];
    const double vn = c.nx * e.v[c.ix] + c.nz * e.v[c.iz];
    const double an = c.nx * e.a[c.ix] + c.nz * e.a[c.iz];
    const double N = m * (g + dt * vn + dt * tau * an) / (dt * tau);
    if (N <= 0.0) continue; // separating: the node leaves the plane
    const double vt = tx * e.v[c.ix] + tz * e.v[c.iz];
    const double at = tx * e.a[c.ix] + tz * e.a[c.iz];
    const ContactPlane& p = core.pb.contacts[c.plane];
    double F = -m * (vt / tau + at); // stick
    if (std::abs(F) > p.mu_static * N) {
      F = (F > 0 ? 1.0 : -1.0) * p.mu_dynamic * N; // Coulomb sliding
      c.slide = true;
    }
    // force of the plane on the soil node: −N n + F t
    c.N = N;
    c.Ft = F;
    c.fx = -N * c.nx + F * tx;
    c.fz = -N * c.nz + F * tz;
    e.a[c.ix] += c.fx / m;
    e.a[c.iz] += c.fz / m;
  }
}

// A moving rigid body in Coulomb contact with the soil (Region::contact with a DoF not fixed):
// the kinematic contact of apply_contacts against a moving surface, solved with the body's
// equation of motion. Node i (lumped mass m_i, trial acceleration a*_i = f_i/m_i) touches the body
// at its reference point X_i, where the body's surface moves with J_i q (J_i = S(X_i), rigid_at).
// With gap g and normal velocity v_n of the node relative to that surface, the targets of the
// node's relative acceleration are those of apply_contacts (Carpenter, Taylor & Katona 1991):
//   normal  d_n = −(g + Δt v_n)/(Δt τ)   (back on the surface at the next step)
//   stick   d_t = −v_t/τ                 (no relative tangential velocity at the next velocity)
// Sticking: r_i = m_i (d_i − a*_i + J_i q̈) (the force of the body on the node); sliding:
// r_i = N_i w_i, w_i = −n + s μ_d t, N_i = m_i (n·a*_i − d_n − n·J_i q̈); open: r_i = 0.
// The body M q̈ = Q − Σ J_iᵀ r_i; eliminating r_i gives the 3×3 Schur complement
//   (M + Σ_stick m J_iᵀJ_i − Σ_slide m J_iᵀ w_i n_iᵀ J_i) q̈ = Q − Σ_stick m J_iᵀ(d_i − a*_i)
//                                                              − Σ_slide m J_iᵀ w_i (n·a*_i − d_n)
// over the free DoFs (fixed ones at rest, prescribed ones with their motion's second
// difference). The active set (open / stick / slide and the slip direction) starts from the last
// step's and is updated from the Coulomb cone and the sign of N with the solved q̈, at most 8
// passes; the forces are those of the last solve, so that soil + body momentum is exact whatever
// the set (only the Coulomb law can be violated by an unsettled set: counted in `unsettled`).
void Explicit::contact_body(Body& b, double dt) {
  const Problem& pb = core.pb;
  State& e = state;
  const Region& reg = pb.regions[b.region];
  const Point p = reg.pivot;
  const double h = e.contact_dt, tau = e.contact_tau;
  // generalised external force: weight, the loads (resultant at load_point and a couple: Q =
  // (Fx, Fz, M + (l − p) × F)) and mass-proportional Rayleigh damping −α M_q q̇ (as on the tied
  // body's dofs)
  const double Fx = core.lambda * reg.force_x(core.t), Fz = core.lambda * reg.force_z(core.t);
  double Q[3] = {b.Qw[0] + Fx, b.Qw[1] + Fz,
                 b.Qw[2] + core.lambda * reg.moment(core.t) + (reg.load_point.x - p.x) * Fz -
                     (reg.load_point.z - p.z) * Fx};
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) Q[a] -= pb.rayleigh_alpha * b.M[a][c] * b.qv[c];
  double ap[3] = {0, 0, 0};
  int fr[3];
  const int nf = free_and_prescribed(reg, core.t, dt, fr, ap);
  const bool active = h > 0 && tau > 0;
  // per contact: mass, J, trial acceleration, normal/tangent and the targets
  struct Row {
    double m, J[2][3], as[2], n[2], tg[2], dn, dtg, mus, mud;
  };
  std::vector<Row> rows(b.contacts.size());
  for (std::size_t k = 0; k < b.contacts.size(); ++k) {
    const auto& c = e.contacts[b.contacts[k]];
    Row& w = rows[k];
    w.m = e.mass[c.ix];
    w.J[0][0] = 1, w.J[0][1] = 0, w.J[0][2] = -(c.z - p.z);
    w.J[1][0] = 0, w.J[1][1] = 1, w.J[1][2] = c.x - p.x;
    // the free acceleration f/m without FLAC local damping: −α|f| sign(v) of a node pressed on
    // the body is a large force (f is balanced by the contact force) flipping with the sign of a
    // near-zero velocity, which the contact would pass on to the body as a chatter; a node in
    // contact is damped through its body (and by Rayleigh damping, which is in f)
    w.as[0] = e.f[c.ix] / w.m;
    w.as[1] = e.f[c.iz] / w.m;
    w.n[0] = c.nx, w.n[1] = c.nz, w.tg[0] = -c.nz, w.tg[1] = c.nx;
    double ub[2], vb[2];
    rigid_at(b.q, p, c.x, c.z, ub);
    rigid_at(b.qv, p, c.x, c.z, vb);
    const double du_rel[2] = {e.u[c.ix] - ub[0], e.u[c.iz] - ub[1]};
    const double dv[2] = {e.v[c.ix] - vb[0], e.v[c.iz] - vb[1]};
    const double g = w.n[0] * du_rel[0] + w.n[1] * du_rel[1]; // penetration positive
    const double vn = w.n[0] * dv[0] + w.n[1] * dv[1], vt = w.tg[0] * dv[0] + w.tg[1] * dv[1];
    w.dn = active ? -(g + h * vn) / (h * tau) : 0.0; // Carpenter et al. 1991, normal
    w.dtg = active ? -vt / tau : 0.0;                // stick: no relative tangential velocity
    const ContactPlane& cp = pb.contacts[c.plane];
    w.mus = cp.mu_static;
    w.mud = cp.mu_dynamic;
  }
  std::vector<int> status(rows.size());
  std::vector<double> sign(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    status[k] = active ? e.contacts[b.contacts[k]].status : 0;
    sign[k] = e.contacts[b.contacts[k]].sign;
  }
  double qa[3] = {ap[0], ap[1], ap[2]};
  // J_i q̈ (the body's surface acceleration at X_i)
  auto surface = [&](const Row& w, double out[2]) {
    for (int r = 0; r < 2; ++r) out[r] = w.J[r][0] * qa[0] + w.J[r][1] * qa[1] + w.J[r][2] * qa[2];
  };
  bool settled = false;
  for (int pass = 0; pass < 8; ++pass) {
    ++b.passes;
    double A[3][3], R[3];
    for (int a = 0; a < 3; ++a) {
      R[a] = Q[a];
      for (int c = 0; c < 3; ++c) A[a][c] = b.M[a][c];
    }
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const Row& w = rows[k];
      if (status[k] == 0) continue;
      if (status[k] == 1) { // stick: A += m JᵀJ, R −= m Jᵀ(d − a*)
        const double d[2] = {w.dn * w.n[0] + w.dtg * w.tg[0] - w.as[0],
                             w.dn * w.n[1] + w.dtg * w.tg[1] - w.as[1]};
        for (int a = 0; a < 3; ++a) {
          R[a] -= w.m * (w.J[0][a] * d[0] + w.J[1][a] * d[1]);
          for (int c = 0; c < 3; ++c)
            A[a][c] += w.m * (w.J[0][a] * w.J[0][c] + w.J[1][a] * w.J[1][c]);
        }
      } else { // slide: A −= m Jᵀw nᵀJ, R −= m Jᵀw (n·a* − d_n)
        const double ww[2] = {-w.n[0] + sign[k] * w.mud * w.tg[0],
                              -w.n[1] + sign[k] * w.mud * w.tg[1]};
        const double na = w.n[0] * w.as[0] + w.n[1] * w.as[1] - w.dn;
        for (int a = 0; a < 3; ++a) {
          const double Jw = w.J[0][a] * ww[0] + w.J[1][a] * ww[1];
          R[a] -= w.m * Jw * na;
          for (int c = 0; c < 3; ++c)
            A[a][c] -= w.m * Jw * (w.n[0] * w.J[0][c] + w.n[1] * w.J[1][c]);
        }
      }
    }
    double Af[3][3], Rf[3];
    for (int x = 0; x < nf; ++x) {
      Rf[x] = R[fr[x]];
      for (int c = 0; c < 3; ++c)
        if (reg.mode[c] != Region::Mode::Free) Rf[x] -= A[fr[x]][c] * ap[c];
      for (int y = 0; y < nf; ++y) Af[x][y] = A[fr[x]][fr[y]];
    }
    if (nf > 0) solve_small(nf, Af, Rf);
    for (int x = 0; x < nf; ++x) qa[fr[x]] = Rf[x];
    if (!active) {
      settled = true;
      break;
    }
    // the law of apply_contacts with the relative trial acceleration a*_i − J_i q̈
    bool changed = false;
    std::vector<int> next(rows.size());
    std::vector<double> nsign(rows.size());
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const Row& w = rows[k];
      double js[2];
      surface(w, js);
      const double ar[2] = {w.as[0] - js[0], w.as[1] - js[1]};
      const double N = w.m * (w.n[0] * ar[0] + w.n[1] * ar[1] - w.dn);
      nsign[k] = sign[k];
      if (N <= 0.0) {
        next[k] = 0;
      } else {
        const double F = w.m * (w.dtg - (w.tg[0] * ar[0] + w.tg[1] * ar[1]));
        if (std::abs(F) > w.mus * N) {
          next[k] = 2;
          nsign[k] = F > 0 ? 1.0 : -1.0;
        } else {
          next[k] = 1;
        }
      }
      changed = changed || next[k] != status[k] || (next[k] == 2 && nsign[k] != sign[k]);
    }
    if (!changed) {
      settled = true;
      break;
    }
    if (pass == 7) break; // keep the forces of the last solve
    status = next;
    sign = nsign;
  }
  if (!settled) ++b.unsettled;
  // the forces of the last solve: on the soil nodes, and −Σ J_iᵀ r_i on the body (in q̈)
  for (std::size_t k = 0; k < rows.size(); ++k) {
    auto& c = e.contacts[b.contacts[k]];
    const Row& w = rows[k];
    double js[2], r[2] = {0.0, 0.0};
    surface(w, js);
    if (status[k] == 1) {
      for (int d = 0; d < 2; ++d) r[d] = w.m * (w.dn * w.n[d] + w.dtg * w.tg[d] - w.as[d] + js[d]);
    } else if (status[k] == 2) {
      const double N = w.m * (w.n[0] * (w.as[0] - js[0]) + w.n[1] * (w.as[1] - js[1]) - w.dn);
      for (int d = 0; d < 2; ++d) r[d] = N * (-w.n[d] + sign[k] * w.mud * w.tg[d]);
    }
    c.status = status[k];
    c.sign = sign[k];
    c.fx = r[0];
    c.fz = r[1];
    c.N = -(r[0] * w.n[0] + r[1] * w.n[1]);
    c.Ft = r[0] * w.tg[0] + r[1] * w.tg[1];
    c.slide = status[k] == 2;
    if (status[k] == 0) continue; // open: the free (damped) acceleration stays
    e.a[c.ix] = w.as[0] + r[0] / w.m;
    e.a[c.iz] = w.as[1] + r[1] / w.m;
  }
  for (int a = 0; a < 3; ++a) b.qa[a] = qa[a];
}

std::vector<Explicit::Contact> Model::Impl::contact_state(std::size_t plane) const {
  std::vector<Explicit::Contact> out;
  if (ex.state.ready) {
    for (const auto& c : ex.state.contacts)
      if (c.plane == plane) out.push_back(c);
    return out;
  }
  // before the explicit run (K0 state, seating): the reactions of the constraints that hold the
  // nodes on the plane, f_int − f_ext at their dofs (the force of the soil on the support)
  // (collective: each rank reads the reactions at its owned dofs, the sum gives every rank all)
  const auto nodes = contact_nodes();
  const auto& on_plane = nodes.at(plane);
  // a node at a corner of a structure (on two of its faces) carries one reaction: it counts on
  // the structure's first face only (as Explicit::contact_setup keeps one contact per node)
  std::set<types::global_dof_index> earlier;
  const int region = pb.contacts.at(plane).region;
  for (std::size_t k = 0; region >= 0 && k < plane; ++k)
    if (pb.contacts[k].region == region)
      for (const ContactNode& n : nodes[k]) earlier.insert(n.ix);
  std::vector<double> r(2 * on_plane.size(), 0.0);
  for (std::size_t k = 0; k < on_plane.size(); ++k) {
    const ContactNode& n = on_plane[k];
    r[2 * k] = owned.is_element(n.ix) && hom.is_constrained(n.ix) ? im.res(n.ix) : 0.0;
    r[2 * k + 1] = owned.is_element(n.iz) && hom.is_constrained(n.iz) ? im.res(n.iz) : 0.0;
  }
  allreduce_sum(r, comm);
  for (std::size_t k = 0; k < on_plane.size(); ++k) {
    const ContactNode& n = on_plane[k];
    if (earlier.count(n.ix)) continue;
    Explicit::Contact c = Explicit::contact_at(n, plane);
    const double rx = r[2 * k], rz = r[2 * k + 1];
    c.fx = rx; // the plane's force on the soil: f_int − f_ext at a held dof
    c.fz = rz;
    c.N = -(c.fx * c.nx + c.fz * c.nz);
    c.Ft = c.fx * -c.nz + c.fz * c.nx;
    if (c.N <= 0.0) c.fx = c.fz = c.N = c.Ft = 0.0;
    out.push_back(c);
  }
  return out;
}

ContactForce Model::contact_force(std::size_t plane) const {
  const Impl& m = *impl_;
  const ContactPlane& p = m.pb.contacts.at(plane);
  ContactForce out;
  Point pivot;
  if (p.region >= 0) pivot = m.pb.regions.at(static_cast<std::size_t>(p.region)).pivot;
  for (const auto& c : m.contact_state(plane)) {
    if (m.ex.state.ready) {
      double ub[2] = {0.0, 0.0}; // a moving body's surface displacement under the node
      if (c.body >= 0) {
        const auto& b = m.ex.state.bodies[c.body];
        rigid_at(b.q, m.pb.regions[b.region].pivot, c.x, c.z, ub);
      }
      const double ut = -c.nz * (m.ex.state.u[c.ix] - ub[0]) + c.nx * (m.ex.state.u[c.iz] - ub[1]);
      out.max_slip = std::max(out.max_slip, std::abs(ut));
    }
    if (c.N <= 0.0) {
      ++out.open;
      continue;
    }
    ++out.nodes;
    out.sliding += c.slide ? 1 : 0;
    out.fx -= c.fx; // the soil pushes the plane with −(the plane's force on it)
    out.fz -= c.fz;
    out.moment += -(c.x - pivot.x) * c.fz + (c.z - pivot.z) * c.fx; // (X − p) × (−f)
    out.normal += c.N;
    out.tangential += std::abs(c.Ft);
  }
  if (plane < m.ex.state.contact_work.size()) out.dissipated = -m.ex.state.contact_work[plane];
  return out;
}

std::string Model::contact_body_summary() const {
  const Impl& m = *impl_;
  std::ostringstream s;
  for (const auto& b : m.ex.state.bodies) {
    if (!b.contact) continue;
    const long steps = std::max(1L, m.ex.state.steps);
    s << "contact body '" << m.pb.regions[b.region].name << "': " << b.contacts.size()
      << " soil nodes in Coulomb contact with its faces, " << double(b.passes) / double(steps)
      << " active-set passes per step, " << b.unsettled << " of " << m.ex.state.steps
      << " steps ended with an unsettled set (8 passes)\n";
  }
  return s.str();
}

} // namespace demfem::continuum::fem
