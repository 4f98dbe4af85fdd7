// Engine: contact forces — the pair loop (parts and the adaptive team), boundary contacts, the law
// chosen once per step.
#include "demfem/dem/engine.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <optional>
#include <type_traits>
#include <variant>

#include <fmt/format.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "engine_internal.hpp"
#include "pair_kernel.hpp"
#include "spin_barrier.hpp"

namespace demfem::dem {

using namespace detail;

// ---- forces -------------------------------------------------------------------------------------

// Geometry and kinematics of the pair (i, j) for the law (sign convention: contact/contact.hpp).
// One definition for the one-pass loop and the blocked loop's scalar path, so both compute the
// same bits. dx, dz = x_i − x_j; rsum = r_i + r_j; d2 = dx² + dz².
struct PairGeometry {
  ContactInput in;
  double nx, nz, li, lj;
};
inline PairGeometry pair_geometry(const Particles& p, std::uint32_t i, std::uint32_t j, double dx,
                                  double dz, double rsum, double d2) {
  PairGeometry g;
  const double ri = p.radius[i], rj = p.radius[j];
  const double dvx = p.vx[i] - p.vx[j], dvz = p.vz[i] - p.vz[j];
  const double dist = std::sqrt(d2);
  const double delta = rsum - dist; // eq. 2.3
  const double inv = dist > 0.0 ? 1.0 / dist : 0.0;
  g.nx = dx * inv; // from j to i (eq. 2.4: cos α, sin α)
  g.nz = dz * inv;
  const double tx = -g.nz, tz = g.nx;
  g.li = ri - 0.5 * delta; // l_i + l_j = |x_i − x_j|
  g.lj = rj - 0.5 * delta;
  g.in.delta = delta;
  g.in.vn = -(dvx * g.nx + dvz * g.nz);                                    // eq. 2.5, approach
  g.in.vs = dvx * tx + dvz * tz - (g.li * p.omega[i] + g.lj * p.omega[j]); // eq. 2.5, slip
  g.in.m_eff = p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j]);
  g.in.r_eff = ri * rj / rsum;
  g.in.wr = p.omega[i] - p.omega[j]; // relative rolling rate
  return g;
}

// Energy sums of a range of pairs: friction, damping, normal spring, shear spring (the rebound's
// is booked by apply_rebounds).
struct PairEnergies {
  static constexpr std::size_t kCount = 4;
  double fric = 0.0, damp = 0.0, n = 0.0, s = 0.0;
  void add_to(double* e) const {
    e[0] += fric;
    e[1] += damp;
    e[2] += n;
    e[3] += s;
  }
};

// One pair (i, j) through the law (its extra history: `extra`): its energies are added to `en`, a
// rebound at first touch to `events`; false when the contact ended (no force), else the force on
// i (fx, fz: eq. 2.15, t = (−n_z, n_x)) and the torque terms l_i f_t − m_r, l_j f_t + m_r (the
// torques are −ti on i and −tj on j).
struct PairForce {
  double fx, fz, ti, tj;
};
template <class Law>
inline bool law_on_pair(const Law& law, const PairGeometry& g, const ContactInput& in,
                        ContactHistory& h, double* extra, PairEnergies& en, PairForce& f,
                        std::vector<ReboundEvent>& events, std::uint32_t i, std::uint32_t j) {
  const ContactResult r = law.evaluate(in, h, extra);
  en.fric += r.e_friction;
  if (!r.touching) return false;
  en.damp += r.e_damping;
  en.n += r.e_normal;
  en.s += r.e_shear;
  if (r.rebound_vn > 0.0)
    events.push_back({.i = i,
                      .j = j,
                      .nx = g.nx,
                      .nz = g.nz,
                      .vn = r.rebound_vn,
                      .to = r.rebound_to,
                      .m_eff = in.m_eff});
  const double fnt = r.fn;
  f.fx = fnt * g.nx + r.ft * -g.nz;
  f.fz = fnt * g.nz + r.ft * g.nx;
  f.ti = g.li * r.ft;
  f.tj = g.lj * r.ft;
  if constexpr (Law::Rolling::kActive) { // the rolling couple: +m_r on i, −m_r on j
    f.ti -= r.mr;
    f.tj += r.mr;
  }
  return true;
}

// The first pair whose overlap exceeds max_overlap·min(r_i, r_j) (the blow-up check).
inline void note_overlap(double delta, double limit, std::uint32_t i, std::uint32_t j, bool& failed,
                         std::uint32_t* fail_pair) {
  if (delta > limit && !failed) {
    failed = true;
    fail_pair[0] = i;
    fail_pair[1] = j;
  }
}

// Particle–particle forces of the owners i0 ≤ i < i1 (pairs i < j), accumulated into fx, fz, tq
// (the particle arrays, or one thread's buffers). energies[0..3]: friction, damping, normal
// spring, shear spring of these pairs (PairEnergies). fail_pair: the first pair above max_overlap
// (i, j), left unchanged when none.
template <class Law>
void Engine::pair_range(const Law& law, std::size_t i0, std::size_t i1, const ForceTarget& out,
                        double* energies, std::uint32_t* fail_pair) {
  if constexpr (std::is_same_v<Law, ReboundModel>) {
    if (!law.law.normal.bond.tension && config_.pair_kernel != EngineConfig::PairKernel::scalar) {
      pair_range_rebound(law, i0, i1, out, energies, fail_pair);
      return;
    }
  }
  const double dt = dt_;
  double* __restrict fx = out.fx;
  double* __restrict fz = out.fz;
  double* __restrict tq = out.tq;
  const double* __restrict x = p_.x.data();
  const double* __restrict z = p_.z.data();
  const double* __restrict rad = p_.radius.data();
  const auto& mats = config_.materials;
  const bool one_material = friction_uniform_; // every pair: friction_mus_, friction_mud_
  PairEnergies en;
  const double max_ov = config_.max_overlap;
  bool failed = fail_pair[0] != ~0u;
  for (std::size_t i = i0; i < i1; ++i) {
    const std::uint32_t kb = nl_.start[i], ke = nl_.start[i + 1];
    if (kb == ke) continue;
    const double xi = x[i], zi = z[i], ri = rad[i];
    double fxi = 0.0, fzi = 0.0, ti = 0.0;
    for (std::uint32_t k = kb; k < ke; ++k) {
      const std::uint32_t j = nl_.j[k];
      ContactHistory& h = nl_.hist[k];
      double* extra = Law::kHistory > 0 ? nl_.xh.data() + k * Law::kHistory : nullptr;
      const double dx = xi - x[j], dz = zi - z[j];
      const double rsum = ri + rad[j];
      const double d2 = dx * dx + dz * dz;
      if (d2 >= rsum * rsum && h.flags == 0) continue; // not touching, no history
      const PairGeometry g = pair_geometry(p_, static_cast<std::uint32_t>(i), j, dx, dz, rsum, d2);
      ContactInput in = g.in;
      if (one_material) {
        in.mu_s = friction_mus_;
        in.mu_d = friction_mud_;
      } else { // the weaker of the two materials
        const auto& a = mats[p_.material[i]];
        const auto& b = mats[p_.material[j]];
        in.mu_s = std::min(a.mu_s, b.mu_s);
        in.mu_d = std::min(a.mu_d, b.mu_d);
      }
      in.dt = dt;
      PairForce f;
      if (!law_on_pair(law, g, in, h, extra, en, f, *out.events, static_cast<std::uint32_t>(i), j))
        continue;
      note_overlap(in.delta, max_ov * std::min(ri, rad[j]), static_cast<std::uint32_t>(i), j,
                   failed, fail_pair);
      fxi += f.fx;
      fzi += f.fz;
      ti -= f.ti;
      out.add_to_partner(j, f.fx, f.fz, f.tj);
    }
    fx[i] += fxi;
    fz[i] += fzi;
    tq[i] += ti;
  }
  en.add_to(energies);
}

// The same pair loop for cundall-rebound without tension, in blocks of compacted entries:
// gather, the vectorised kernel, scatter in list order (pair_kernel.hpp). Bit-identical to
// pair_range's one-pass loop.
void Engine::pair_range_rebound(const ReboundModel& law, std::size_t i0, std::size_t i1,
                                const ForceTarget& out, double* energies,
                                std::uint32_t* fail_pair) {
  double* __restrict fx = out.fx;
  double* __restrict fz = out.fz;
  double* __restrict tq = out.tq;
  detail::PairBlock b; // scratch, written before it is read
  const auto& mats = config_.materials;
  const bool one_material = friction_uniform_; // every pair: friction_mus_, friction_mud_
  const detail::ReboundConstants kc{law.law.normal.spring.p.kn,
                                    law.law.tangential.p.ks,
                                    dt_,
                                    config_.max_overlap,
                                    one_material,
                                    friction_mus_,
                                    friction_mud_};
  const detail::ParticleArrays pa{p_.vx.data(), p_.vz.data(), p_.omega.data(), p_.radius.data(),
                                  p_.mass.data()};
  const detail::Isa isa = detail::kernel_isa(config_.pair_kernel);
  const double* __restrict x = p_.x.data();
  const double* __restrict z = p_.z.data();
  const double* __restrict rad = p_.radius.data();
  const std::uint16_t* __restrict matl = p_.material.data();
  const std::uint32_t* __restrict start = nl_.start.data();
  const std::uint32_t* __restrict partner = nl_.j.data();
  ContactHistory* __restrict hist = nl_.hist.data();
  PairEnergies en;
  bool failed = fail_pair[0] != ~0u;
  const std::uint32_t* __restrict owner = nl_.owner.data();
  // The owner whose forces are being summed: its sums are added to its arrays when the owner
  // changes. (A branch-free form, the sums of an unchanged owner written to a spill slot, was
  // compiled back into this branch, the slot's stores being dead; forced branch-free it measured
  // no faster: bench/RESULTS.md.)
  std::size_t cur = i0;
  double fxi = 0.0, fzi = 0.0, ti = 0.0;
  std::uint32_t k = start[i0];
  const std::uint32_t kend = start[i1];
  while (k < kend) {
    // 1. gather: entries k … k + kSize − 1; the count m advances for a touching entry or one
    //    with history only (branch-free compaction).
    const std::uint32_t ke =
        std::min<std::uint32_t>(kend, k + static_cast<std::uint32_t>(detail::PairBlock::kSize));
    std::size_t m = 0;
    auto gather = [&](auto one_mat) {
      for (; k < ke; ++k) {
        const std::uint32_t i = owner[k], j = partner[k];
        const double dx = x[i] - x[j], dz = z[i] - z[j];
        const double rsum = rad[i] + rad[j];
        const double d2 = dx * dx + dz * dz;
        const ContactHistory& h = hist[k];
        if constexpr (!decltype(one_mat)::value) { // the weaker of the two materials
          const auto& ma = mats[matl[i]];
          const auto& mb = mats[matl[j]];
          b.mus[m] = std::min(ma.mu_s, mb.mu_s);
          b.mud[m] = std::min(ma.mu_d, mb.mu_d);
        }
        b.dx[m] = dx;
        b.dz[m] = dz;
        b.ft[m] = h.ft;
        b.fl[m] = h.flags;
        b.i[m] = i;
        b.j[m] = j;
        b.k[m] = k;
        m += static_cast<std::size_t>(!(d2 >= rsum * rsum) || h.flags != 0);
      }
    };
    if (one_material)
      gather(std::true_type{});
    else
      gather(std::false_type{});
    // 2. geometry and the law of closed, active contacts, vectorised
    detail::rebound_kernel(kc, pa, b, m, isa);
    // 3. scatter in list order; entries outside the kernel's case go through the scalar law.
    //    Without a halo (one part, or a part whose partners all lie in its own range) the partner
    //    forces go straight into the arrays, without the per-entry test of ForceTarget.
    auto scatter = [&](auto with_halo) {
      const detail::ForceTarget o = out; // a copy: the byte-sized flag stores below may alias
                                         // anything reached through a reference
      for (std::size_t e = 0; e < m; ++e) {
        const auto i = static_cast<std::uint32_t>(b.i[e]), j = static_cast<std::uint32_t>(b.j[e]);
        if (i != cur) {
          fx[cur] += fxi;
          fz[cur] += fzi;
          tq[cur] += ti;
          fxi = fzi = ti = 0.0;
          cur = i;
        }
        ContactHistory& h = hist[b.k[e]];
        PairForce f;
        if ((b.fl_new[e] & detail::PairBlock::kSlow) == 0) {
          en.fric += b.e_fric[e];
          en.n += b.e_n[e];
          en.s += b.e_s[e];
          h.ft = b.ft_new[e];
          h.flags = static_cast<std::uint8_t>(b.fl_new[e]);
          h.fn = static_cast<float>(b.fn[e]);
          f = {b.fx[e], b.fz[e], b.ti[e], b.tj[e]};
        } else { // the scalar law, on the geometry as the one-pass loop computes it
          const double dx = x[i] - x[j], dz = z[i] - z[j];
          const double rsum = rad[i] + rad[j];
          const PairGeometry g = pair_geometry(p_, i, j, dx, dz, rsum, dx * dx + dz * dz);
          ContactInput in = g.in;
          in.mu_s = one_material ? kc.mus0 : b.mus[e];
          in.mu_d = one_material ? kc.mud0 : b.mud[e];
          in.dt = kc.dt;
          if (!law_on_pair(law, g, in, h, nullptr, en, f, *o.events, i, j)) continue;
          note_overlap(in.delta, kc.max_overlap * std::min(rad[i], rad[j]), i, j, failed,
                       fail_pair);
        }
        fxi += f.fx;
        fzi += f.fz;
        ti -= f.ti;
        if constexpr (decltype(with_halo)::value) {
          o.add_to_partner(j, f.fx, f.fz, f.tj);
        } else {
          fx[j] -= f.fx;
          fz[j] -= f.fz;
          tq[j] -= f.tj;
        }
      }
    };
    if (out.hx)
      scatter(std::true_type{});
    else
      scatter(std::false_type{});
  }
  if (kend > start[i0]) {
    fx[cur] += fxi;
    fz[cur] += fzi;
    tq[cur] += ti;
  }
  en.add_to(energies);
}

int Engine::team_size() const {
  const int T = threads_in_use();
  return team_ > 0 ? std::min(team_, T) : T;
}

std::pair<std::size_t, std::size_t> Engine::team_member() {
#ifdef _OPENMP
  return {static_cast<std::size_t>(omp_get_thread_num()),
          static_cast<std::size_t>(omp_get_num_threads())};
#else
  return {0, 1};
#endif
}

int Engine::threads_in_use() const {
  if (p_.size() < config_.parallel_min_particles) return 1;
  int t = config_.threads;
#ifdef _OPENMP
  if (t <= 0) t = omp_get_max_threads();
#else
  t = 1;
#endif
  return std::max(t, 1);
}

template <class Law> void Engine::contact_forces(const Law& law) {
  const std::size_t n = p_.size();
  reset_step_sums();
  if (threads_in_use() <= 1) {
    double en[kPartEnergies] = {};
    std::uint32_t fail[2] = {~0u, ~0u};
    std::fill(p_.fx.begin(), p_.fx.end(), 0.0);
    std::fill(p_.fz.begin(), p_.fz.end(), 0.0);
    std::fill(p_.torque.begin(), p_.torque.end(), 0.0);
    fp_.rebound_events[0].clear();
    fp_.event_parts = 1;
    const ForceTarget ft{
        p_.fx.data(),          p_.fz.data(), p_.torque.data(), nullptr, nullptr, nullptr, n,
        &fp_.rebound_events[0]};
    pair_range(law, 0, n, ft, en, fail);
    if (fp_.bnd_sums.empty()) fp_.bnd_sums.resize(1);
    boundary_range(law, 0, nl_.bnd_i.size(), fp_.bnd_sums[0]);
    finish_forces(en, fail);
    return;
  }
  const std::size_t tcount = begin_parts();
  const auto body = body_acceleration();
  // The region's work for thread t0 of a team of ts. A team of one (the adaptive team when the
  // other cores are busy) runs it without a parallel region, its barrier then being a no-op:
  // with the region, a step of 10⁴ disks on one thread took ≈ 10 µs (3–5 %) longer
  // (bench/RESULTS.md).
  const auto region = [&](std::size_t t0, std::size_t ts) {
    for (std::size_t t = t0; t < tcount; t += ts) part_forces(law, t);
#pragma omp barrier
    for (std::size_t u = t0; u < tcount; u += ts) part_halos(u);
    // Without rebound impulses (apply_rebounds changes the forces of any particle) each part's
    // forces are final now: the thread integrates its parts without leaving the region
    // (integrate() then only adds up the parts). Every part's events are known at the barrier
    // above, so no second barrier is needed.
    if (parts_quiet())
      for (std::size_t u = t0; u < tcount; u += ts)
        integrate_range(fp_.split[u], fp_.split[u + 1], body.first, body.second, fp_.integrated[u]);
  };
  if (team_size() <= 1) {
    region(0, 1);
  } else {
#pragma omp parallel num_threads(team_size())
    {
      const auto [t0, ts] = team_member();
      region(t0, ts);
    }
  }
  fp_.integrated_parts = parts_quiet() ? tcount : 0;
  end_parts();
}

template <class Law>
long long Engine::team_steps(const Law& law, long long max_steps, double t_stop) {
  const int team = team_size();
  if (max_steps <= 0 || threads_in_use() <= 1 || team <= 1 || !(dt_ > 0.0) || !en_.pe_ref_set ||
      friction_dirty_ || !failure_.empty() || !(time_ < t_stop - 0.5 * dt_) || rebuild_pending())
    return 0;
  if (!tuner_.started && !tuner_.fixed && config_.adaptive_threads) return 0; // step() starts it
  using Clock = std::chrono::steady_clock;
  // One step here is step()'s: the forces of the parts (part_forces, part_halos), the rebound
  // impulses when there are any (apply_rebounds), the integration of each part on the thread
  // that computed its forces, then the serial rest on thread 0 (the parts' sums, integrate()'s
  // sums, the structures, the clock, the adaptive team, whether the next step needs a rebuild)
  // while the others wait. The same operations in the same order as step(), so the same bits.
  reset_step_sums();
  std::size_t tcount = begin_parts();
  // Spin ≈ 80 µs (4,096 pauses of ≈ 19 ns on this project's Zen 5 machines) before sleeping, a
  // step's imbalance being a few µs; about 1 µs when the team has more threads than the
  // processors it may use (a spinning thread would hold the processor a descheduled one needs:
  // 400 steps of 1,000 disks on 3 threads and 2 processors took 1 s instead of 0.03 s).
  int procs = 1;
#ifdef _OPENMP
  procs = omp_get_num_procs();
#endif
  const unsigned spins = team <= procs ? 4096u : 64u;
  std::optional<detail::SpinBarrier> barrier;
  long long done = 0;
  bool stop = false;
  // The serial parts run on thread 0 inside the region: an exception there (what step() would
  // throw) stops the region after this step and is thrown from here, not through OpenMP.
  std::exception_ptr error;
  auto serial = [&](auto&& work) {
    try {
      work();
    } catch (...) {
      if (!error) error = std::current_exception();
    }
  };
  auto step_start = Clock::now();
#pragma omp parallel num_threads(team)
  {
    const auto [t0, ts] = team_member();
    if (t0 == 0) barrier.emplace(static_cast<unsigned>(ts), spins); // the team OpenMP gave
#pragma omp barrier
    while (true) {
      for (std::size_t t = t0; t < tcount; t += ts) part_forces(law, t);
      barrier->wait();
      for (std::size_t u = t0; u < tcount; u += ts) part_halos(u);
      const bool quiet = parts_quiet();
      if (!quiet) { // the impulses change the forces of particles of any part: all halos first
        barrier->wait();
        if (t0 == 0)
          serial([&] {
            end_parts();
            apply_rebounds();
          });
        barrier->wait();
      }
      const auto body = body_acceleration();
      for (std::size_t u = t0; u < tcount; u += ts)
        integrate_range(fp_.split[u], fp_.split[u + 1], body.first, body.second, fp_.integrated[u]);
      barrier->wait();
      if (t0 == 0)
        serial([&] {
          if (quiet) {
            end_parts();
            apply_rebounds(); // none: it only clears its list
          }
          const auto forces_done = Clock::now();
          stats_.force_seconds += std::chrono::duration<double>(forces_done - step_start).count();
          fp_.integrated_parts = tcount;
          integrate(); // the parts' sums only
          update_structures();
          time_ += dt_;
          ++stats_.steps;
          ++stats_.team_region_steps;
          tune_team();
          ++done;
          stop = done >= max_steps || !failure_.empty() || !(time_ < t_stop - 0.5 * dt_) ||
                 team_size() != team || rebuild_pending();
          if (!stop) {
            reset_step_sums();
            tcount = begin_parts();
          }
          step_start = Clock::now();
        });
      if (t0 == 0 && error) stop = true;
      barrier->wait();
      if (stop) break;
    }
  }
  if (error) std::rethrow_exception(error);
  return done;
}

long long Engine::run_until(double t_stop, long long max_steps) {
  resume_team_clock();
  long long k = 0;
  while (k < max_steps && failure_.empty()) {
    if (dt_ > 0.0 && !(time_ < t_stop - 0.5 * dt_)) break;
    const long long m = std::visit(
        [&](const auto& law) { return team_steps(law, max_steps - k, t_stop); }, config_.law);
    if (m > 0) {
      k += m;
      continue;
    }
    step();
    ++k;
  }
  pause_team_clock();
  return k;
}

void Engine::pause_team_clock() {
  if (tuner_.started && !tuner_.fixed && config_.adaptive_threads && threads_in_use() > 1)
    tuner_.paused_at = team_now();
}

void Engine::resume_team_clock() {
  if (!tuner_.paused_at) return;
  // The window (and its probe's pace) counts the engine's own time only: the caller's time
  // between the calls is added to the window's start. Before, a window that spanned the
  // snapshot of a 10⁵-disk run (0.3 s) read as a slow full team: 35–38 % of the steps then ran
  // on one thread against 0.5 % without snapshots (bench/RESULTS.md).
  tuner_.t0 += team_now() - *tuner_.paused_at;
  tuner_.paused_at.reset();
}

void Engine::reset_step_sums() {
  for (auto& b : bd_.list) b.reaction_x = b.reaction_z = 0.0;
  for (auto& st : bd_.structures) st.soil_fx = st.soil_fz = st.soil_moment = 0.0;
  if (fp_.rebound_events.size() < kMaxParts) fp_.rebound_events.resize(kMaxParts);
}

std::size_t Engine::begin_parts() {
  const std::size_t n = p_.size();
  // Deterministic for a fixed thread count: part t takes the owners in fp_.split[t]…fp_.split[t+1]
  // (equal shares of pair entries). Computed once per list.
  const auto tcount = std::min(static_cast<std::size_t>(threads_in_use()), kMaxParts);
  if (fp_.version != nl_.version || fp_.split.size() != tcount + 1) {
    fp_.split.assign(tcount + 1, n);
    fp_.split[0] = 0;
    const std::uint32_t total = nl_.start[n];
    for (std::size_t t = 1; t < tcount; ++t) {
      const auto target = static_cast<std::uint32_t>(
          static_cast<double>(total) * static_cast<double>(t) / static_cast<double>(tcount));
      fp_.split[t] = static_cast<std::size_t>(
          std::lower_bound(nl_.start.begin(), nl_.start.begin() + static_cast<std::ptrdiff_t>(n),
                           target) -
          nl_.start.begin());
      fp_.split[t] = std::max(fp_.split[t], fp_.split[t - 1]);
    }
    // Part t's halo reaches its largest partner only: in column order (reorder()) that is a
    // couple of columns past its range, not the rest of the particles.
    // Its owners before fp_.halo_from[t] have no partner beyond the part (the scatter then skips
    // the own/halo test per entry): all but its last couple of columns.
    fp_.halo_end.assign(tcount, n);
    fp_.halo_from.assign(tcount, n);
    for (std::size_t t = 0; t < tcount; ++t) {
      const std::size_t end = fp_.split[t + 1];
      std::size_t e = end, from = end;
      for (std::size_t i = fp_.split[t]; i < end; ++i)
        for (std::uint32_t k = nl_.start[i]; k < nl_.start[i + 1]; ++k) {
          e = std::max<std::size_t>(e, nl_.j[k] + 1u);
          if (nl_.j[k] >= end) from = std::min(from, i);
        }
      fp_.halo_end[t] = e;
      fp_.halo_from[t] = from;
    }
    // Part t (owners s_t … s_{t+1} − 1) adds straight into the particle force arrays for the
    // particles of its own range (its owners, and partners j < s_{t+1}: a partner is never below
    // its owner) and into its halo buffer for partners beyond it (s_{t+1} ≤ j < fp_.halo_end[t]);
    // no two parts write the same element. The halos are then added per particle in part order, so
    // the result depends on T only, whichever threads run the parts (the adaptive team).
    fp_.halo_off.assign(tcount + 1, 0);
    for (std::size_t t = 0; t < tcount; ++t)
      fp_.halo_off[t + 1] = fp_.halo_off[t] + 3 * (fp_.halo_end[t] - fp_.split[t + 1]);
    if (fp_.tbuf.size() < fp_.halo_off[tcount]) fp_.tbuf.resize(fp_.halo_off[tcount]);
    // Part t's boundary entries: those of its particles (nl_.bnd_i is sorted by particle).
    fp_.bnd_split.resize(tcount + 1);
    for (std::size_t t = 0; t <= tcount; ++t)
      fp_.bnd_split[t] =
          static_cast<std::size_t>(std::lower_bound(nl_.bnd_i.begin(), nl_.bnd_i.end(),
                                                    static_cast<std::uint32_t>(fp_.split[t])) -
                                   nl_.bnd_i.begin());
    fp_.bnd_split[tcount] = nl_.bnd_i.size();
    fp_.version = nl_.version;
  }
  std::fill(fp_.en.begin(), fp_.en.begin() + static_cast<std::ptrdiff_t>(kPartEnergies * tcount),
            0.0);
  std::fill(fp_.fail.begin(), fp_.fail.begin() + static_cast<std::ptrdiff_t>(2 * tcount), ~0u);
  fp_.event_parts = tcount;
  if (fp_.bnd_sums.size() < tcount) fp_.bnd_sums.resize(tcount);
  return tcount;
}

template <class Law> void Engine::part_forces(const Law& law, std::size_t t) {
  double* fxo = p_.fx.data();
  double* fzo = p_.fz.data();
  double* tqo = p_.torque.data();
  const std::size_t end = fp_.split[t + 1], h = fp_.halo_end[t] - end;
  double* hb = h > 0 ? fp_.tbuf.data() + fp_.halo_off[t] : nullptr;
  if (hb) std::fill(hb, hb + 3 * h, 0.0);
  // The part's own range is written by this part only (until the halo sums, part_halos).
  std::fill(fxo + fp_.split[t], fxo + end, 0.0);
  std::fill(fzo + fp_.split[t], fzo + end, 0.0);
  std::fill(tqo + fp_.split[t], tqo + end, 0.0);
  fp_.rebound_events[t].clear();
  const ForceTarget own{fxo, fzo, tqo, nullptr, nullptr, nullptr, end, &fp_.rebound_events[t]};
  const ForceTarget ft{fxo,
                       fzo,
                       tqo,
                       hb,
                       hb ? hb + h : nullptr,
                       hb ? hb + 2 * h : nullptr,
                       end,
                       &fp_.rebound_events[t]};
  const std::size_t from = hb ? fp_.halo_from[t] : end;
  double* en = &fp_.en[kPartEnergies * t];
  std::uint32_t* fail = &fp_.fail[2 * t];
  pair_range(law, fp_.split[t], from, own, en, fail);
  if (from < end) pair_range(law, from, end, ft, en, fail);
  // The part's wall and structure contacts: its own particles only.
  boundary_range(law, fp_.bnd_split[t], fp_.bnd_split[t + 1], fp_.bnd_sums[t]);
}

void Engine::part_halos(std::size_t u) {
  // Part u's particles, on the thread that computed their pair forces (and will integrate them):
  // the halos of parts < u.
  double* fxo = p_.fx.data();
  double* fzo = p_.fz.data();
  double* tqo = p_.torque.data();
  for (std::size_t t = 0; t < u; ++t) {
    const std::size_t end = fp_.split[t + 1], h = fp_.halo_end[t] - end;
    const double* hx = fp_.tbuf.data() + fp_.halo_off[t];
    for (std::size_t i = fp_.split[u]; i < std::min(fp_.split[u + 1], fp_.halo_end[t]); ++i) {
      fxo[i] += hx[i - end];
      fzo[i] += hx[h + i - end];
      tqo[i] += hx[2 * h + i - end];
    }
  }
}

bool Engine::parts_quiet() const { // no rebound impulse in any part
  for (std::size_t t = 0; t < fp_.event_parts; ++t)
    if (!fp_.rebound_events[t].empty() || !fp_.bnd_sums[t].events.empty()) return false;
  return true;
}

void Engine::end_parts() {
  static_assert(PairEnergies::kCount == kPartEnergies);
  double en[kPartEnergies] = {};
  std::uint32_t fail[2] = {~0u, ~0u};
  for (std::size_t t = 0; t < fp_.event_parts; ++t) {
    for (std::size_t q = 0; q < kPartEnergies; ++q) en[q] += fp_.en[kPartEnergies * t + q];
    if (fail[0] == ~0u && fp_.fail[2 * t] != ~0u) {
      fail[0] = fp_.fail[2 * t];
      fail[1] = fp_.fail[2 * t + 1];
    }
  }
  finish_forces(en, fail);
}

void Engine::finish_forces(const double* en, const std::uint32_t* fail) {
  if (fail[0] != ~0u && failure_.empty()) {
    const std::uint32_t i = fail[0], j = fail[1];
    const double delta =
        p_.radius[i] + p_.radius[j] - std::hypot(p_.x[i] - p_.x[j], p_.z[i] - p_.z[j]);
    failure_ = fmt::format("overlap {:.3g} m exceeds max_overlap·r between particles {} and {}",
                           delta, p_.id[i], p_.id[j]);
  }
  en_.friction += en[0];
  en_.damping += en[1];
  en_.normal = en[2];
  en_.shear = en[3];
  add_boundary_sums();
}

void Engine::add_boundary_sums() {
  for (std::size_t t = 0; t < fp_.event_parts; ++t) {
    const BoundarySums& s = fp_.bnd_sums[t];
    en_.friction += s.e_friction;
    en_.damping += s.e_damping;
    en_.normal += s.e_normal;
    en_.shear += s.e_shear;
    for (std::size_t b = 0; b < bd_.list.size(); ++b) {
      bd_.list[b].reaction_x += s.reaction[2 * b];
      bd_.list[b].reaction_z += s.reaction[2 * b + 1];
    }
    for (std::size_t q = 0; q < bd_.structures.size(); ++q) {
      bd_.structures[q].soil_fx += s.soil[3 * q];
      bd_.structures[q].soil_fz += s.soil[3 * q + 1];
      bd_.structures[q].soil_moment += s.soil[3 * q + 2];
    }
    if (s.fail != ~std::size_t{0} && failure_.empty())
      failure_ = fmt::format("overlap {:.3g} m exceeds max_overlap·r between particle {} and "
                             "boundary '{}'",
                             s.fail_delta, p_.id[nl_.bnd_i[s.fail]],
                             bd_.list[bd_.features[nl_.bnd_f[s.fail]].boundary].name);
  }
}

template <class Law>
void Engine::boundary_range(const Law& law, std::size_t k0, std::size_t k1, BoundarySums& s) {
  const double dt = dt_;
  s.reaction.assign(2 * bd_.list.size(), 0.0);
  s.soil.assign(3 * bd_.structures.size(), 0.0);
  s.events.clear();
  s.fail = ~std::size_t{0};
  double e_fric = 0.0, e_damp = 0.0, e_n = 0.0, e_s = 0.0;
  for (std::size_t k = k0; k < k1; ++k) {
    const std::uint32_t i = nl_.bnd_i[k];
    const Feature& F = bd_.features[nl_.bnd_f[k]];
    Boundary& B = bd_.list[F.boundary];
    ContactHistory& h = nl_.bnd_hist[k];
    double* extra = Law::kHistory > 0 ? nl_.bnd_xh.data() + k * Law::kHistory : nullptr;
    if (!B.active) {
      h = ContactHistory{};
      for (std::size_t q = 0; q < Law::kHistory; ++q) extra[q] = 0.0;
      continue;
    }
    const double px = p_.x[i], pz = p_.z[i], ri = p_.radius[i];
    // Closest point q on the feature and the normal from q towards the centre.
    double qx, qz, nx, nz, dist;
    bool valid = true;
    if (F.v0 == F.v1) { // vertex: only in its own Voronoi region (no adjacent edge contact)
      qx = bd_.vx[F.v0];
      qz = bd_.vz[F.v0];
      for (std::int32_t adj : {F.adj0, F.adj1}) {
        if (adj < 0) continue;
        const Feature& S = bd_.features[static_cast<std::size_t>(adj)];
        const double ax = bd_.vx[S.v0], az = bd_.vz[S.v0];
        const double ex = bd_.vx[S.v1] - ax, ez = bd_.vz[S.v1] - az;
        const double t = ((px - ax) * ex + (pz - az) * ez) / (ex * ex + ez * ez);
        if (t > 0.0 && t < 1.0) valid = false;
      }
      const double dx = px - qx, dz = pz - qz;
      dist = std::sqrt(dx * dx + dz * dz);
      nx = dist > 0.0 ? dx / dist : 0.0;
      nz = dist > 0.0 ? dz / dist : 1.0;
    } else {
      const double ax = bd_.vx[F.v0], az = bd_.vz[F.v0];
      const double ex = bd_.vx[F.v1] - ax, ez = bd_.vz[F.v1] - az;
      const double len2 = ex * ex + ez * ez;
      const double t = ((px - ax) * ex + (pz - az) * ez) / len2;
      if (!(t > 0.0 && t < 1.0)) valid = false;
      qx = ax + t * ex;
      qz = az + t * ez;
      if (B.closed) { // structure edge: one-sided, outward normal of a counter-clockwise outline
        const double len = std::sqrt(len2);
        nx = ez / len;
        nz = -ex / len;
        dist = (px - ax) * nx + (pz - az) * nz;
        if (dist < -ri) valid = false;
      } else {
        const double dx = px - qx, dz = pz - qz;
        dist = std::sqrt(dx * dx + dz * dz);
        nx = dist > 0.0 ? dx / dist : 0.0;
        nz = dist > 0.0 ? dz / dist : 1.0;
      }
    }
    double delta = ri - dist;
    if (!valid) delta = -1.0e300; // not this feature's contact: ends any history
    const double tx = -nz, tz = nx;
    const double li = ri - std::max(delta, 0.0);
    // Velocity of the boundary at q (rigid structure: v_P + ω × (q − P)).
    double bvx = 0.0, bvz = 0.0;
    StructureState* st = nullptr;
    if (B.structure >= 0) {
      st = &bd_.structures[static_cast<std::size_t>(B.structure)];
      const double rx = qx - (st->px0 + st->ux), rz = qz - (st->pz0 + st->uz);
      bvx = st->vx - st->omega * rz;
      bvz = st->vz + st->omega * rx;
    }
    const double dvx = p_.vx[i] - bvx, dvz = p_.vz[i] - bvz;
    ContactInput in;
    in.delta = delta;
    in.vn = -(dvx * nx + dvz * nz);
    in.vs = dvx * tx + dvz * tz - li * p_.omega[i];
    in.m_eff = p_.mass[i];
    in.r_eff = ri;
    in.wr = p_.omega[i] - (st ? st->omega : 0.0); // a wall does not turn
    if (B.own_friction) {
      in.mu_s = B.mu_s;
      in.mu_d = B.mu_d;
    } else {
      in.mu_s = config_.materials[p_.material[i]].mu_s;
      in.mu_d = config_.materials[p_.material[i]].mu_d;
    }
    in.dt = dt;
    if (!valid && h.flags == 0) continue;
    const ContactResult r = law.evaluate(in, h, extra);
    e_fric += r.e_friction;
    if (!r.touching) continue;
    e_damp += r.e_damping;
    e_n += r.e_normal;
    e_s += r.e_shear;
    if (delta > config_.max_overlap * ri && s.fail == ~std::size_t{0}) {
      s.fail = k;
      s.fail_delta = delta;
    }
    if (r.rebound_vn > 0.0)
      s.events.push_back({.i = i,
                          .boundary = static_cast<std::int32_t>(F.boundary),
                          .nx = nx,
                          .nz = nz,
                          .vn = r.rebound_vn,
                          .to = r.rebound_to,
                          .m_eff = in.m_eff,
                          .rx = st ? qx - (st->px0 + st->ux) : 0.0,
                          .rz = st ? qz - (st->pz0 + st->uz) : 0.0});
    const double fnt = r.fn;
    const double Fx = fnt * nx + r.ft * tx, Fz = fnt * nz + r.ft * tz;
    p_.fx[i] += Fx;
    p_.fz[i] += Fz;
    p_.torque[i] -= li * r.ft;
    if constexpr (Law::Rolling::kActive) p_.torque[i] += r.mr; // the rolling couple on i
    s.reaction[2 * F.boundary] -= Fx;
    s.reaction[2 * F.boundary + 1] -= Fz;
    if (st) {
      double* so = &s.soil[3 * static_cast<std::size_t>(B.structure)];
      so[0] -= Fx;
      so[1] -= Fz;
      const double rx = qx - (st->px0 + st->ux), rz = qz - (st->pz0 + st->uz);
      so[2] += rx * (-Fz) - rz * (-Fx);                   // (q − P) × (−F)
      if constexpr (Law::Rolling::kActive) so[2] -= r.mr; // and the rolling couple's reaction
    }
  }
  s.e_friction = e_fric;
  s.e_damping = e_damp;
  s.e_normal = e_n;
  s.e_shear = e_s;
}

void Engine::update_pair_friction() {
  friction_dirty_ = false;
  const auto& mats = config_.materials;
  std::vector<std::uint8_t> used(mats.size(), 0);
  bool in_range = true;
  for (const std::uint16_t m : p_.material) {
    if (m < used.size())
      used[m] = 1;
    else
      in_range = false;
  }
  std::size_t first = mats.size();
  bool uniform = in_range;
  for (std::size_t k = 0; k < mats.size(); ++k) {
    if (!used[k]) continue;
    if (first == mats.size())
      first = k;
    else if (mats[k].mu_s != mats[first].mu_s || mats[k].mu_d != mats[first].mu_d)
      uniform = false;
  }
  if (first == mats.size()) first = 0; // no particles: any
  friction_uniform_ = uniform && !mats.empty();
  friction_mus_ = mats.empty() ? 0.0 : mats[first].mu_s;
  friction_mud_ = mats.empty() ? 0.0 : mats[first].mu_d;
}

void Engine::compute_forces() {
  if (friction_dirty_) update_pair_friction();
  std::visit( // the law chosen once (contact::make_law); one instantiation of the loops per law
      [this](const auto& law) { contact_forces(law); }, config_.law);
  apply_rebounds();
}

void Engine::apply_rebounds() {
  fp_.rebound_all.clear();
  for (std::size_t t = 0; t < fp_.event_parts; ++t)
    fp_.rebound_all.insert(fp_.rebound_all.end(), fp_.rebound_events[t].begin(),
                           fp_.rebound_events[t].end());
  for (std::size_t t = 0; t < fp_.event_parts; ++t)
    fp_.rebound_all.insert(fp_.rebound_all.end(), fp_.bnd_sums[t].events.begin(),
                           fp_.bnd_sums[t].events.end());
  const std::size_t n = fp_.rebound_all.size();
  if (n == 0) return;
  // The particles the events touch, sorted; fp_.rebound_dv holds their velocity change so far.
  fp_.rebound_touched.clear();
  for (const ReboundEvent& e : fp_.rebound_all) {
    fp_.rebound_touched.push_back(e.i);
    if (e.j != ReboundEvent::kBoundary) fp_.rebound_touched.push_back(e.j);
  }
  std::sort(fp_.rebound_touched.begin(), fp_.rebound_touched.end());
  fp_.rebound_touched.erase(std::unique(fp_.rebound_touched.begin(), fp_.rebound_touched.end()),
                            fp_.rebound_touched.end());
  fp_.rebound_dv.assign(2 * fp_.rebound_touched.size(), 0.0);
  // Each event's two slots in fp_.rebound_touched (j: kNone against a boundary), looked up once.
  constexpr std::size_t kNone = ~std::size_t{0};
  auto slot = [&](std::uint32_t i) {
    return static_cast<std::size_t>(
        std::lower_bound(fp_.rebound_touched.begin(), fp_.rebound_touched.end(), i) -
        fp_.rebound_touched.begin());
  };
  fp_.rebound_slot.resize(2 * n);
  fp_.rebound_count.assign(fp_.rebound_touched.size(), 0);
  for (std::size_t k = 0; k < n; ++k) {
    const ReboundEvent& e = fp_.rebound_all[k];
    fp_.rebound_slot[2 * k] = slot(e.i);
    fp_.rebound_slot[2 * k + 1] = e.j != ReboundEvent::kBoundary ? slot(e.j) : kNone;
    ++fp_.rebound_count[fp_.rebound_slot[2 * k]];
    if (fp_.rebound_slot[2 * k + 1] != kNone) ++fp_.rebound_count[fp_.rebound_slot[2 * k + 1]];
  }
  stats_.rebound_contacts += static_cast<long long>(n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t sj = fp_.rebound_slot[2 * k + 1];
    stats_.rebound_shared += (fp_.rebound_count[fp_.rebound_slot[2 * k]] > 1 ||
                              (sj != kNone && fp_.rebound_count[sj] > 1))
                                 ? 1
                                 : 0;
  }
  // Each contact's impulse P_k ≥ 0 brings its approach w_k to K v_n (Newton restitution,
  // contact/rebound.hpp) given the others' impulses: projected Gauss–Seidel sweeps in event order.
  // One event: P = m*(1 − K) v_n in the first sweep. Several on one particle: the sweeps share
  // the collision between them (two coincident floors: one impulse; a disk on two disks: the
  // symmetric split, to 1e-12 of m* v_n).
  fp_.rebound_p.assign(n, 0.0);
  double e_reb = 0.0;
  for (int sweep = 0; sweep < 100; ++sweep) {
    double change = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      const ReboundEvent& e = fp_.rebound_all[k];
      const std::size_t sj = fp_.rebound_slot[2 * k + 1];
      double* dvi = fp_.rebound_dv.data() + 2 * fp_.rebound_slot[2 * k];
      double* dvj = sj != kNone ? fp_.rebound_dv.data() + 2 * sj : nullptr;
      // approach left by the impulses so far: w = v_n − (Δv_i − Δv_j)·n (eq. 2.5's v_n)
      double rel = dvi[0] * e.nx + dvi[1] * e.nz;
      if (dvj) rel -= dvj[0] * e.nx + dvj[1] * e.nz;
      const double w = e.vn - rel;
      const double p_new = std::max(0.0, fp_.rebound_p[k] + e.m_eff * (w - e.to));
      const double dp = p_new - fp_.rebound_p[k];
      if (dp == 0.0) continue;
      // kinetic energy the impulse dp along n removes from the two bodies: dp w − dp²/(2 m*)
      e_reb += dp * w - 0.5 * dp * dp / e.m_eff;
      fp_.rebound_p[k] = p_new;
      dvi[0] += dp * e.nx / p_.mass[e.i];
      dvi[1] += dp * e.nz / p_.mass[e.i];
      if (dvj) {
        dvj[0] -= dp * e.nx / p_.mass[e.j];
        dvj[1] -= dp * e.nz / p_.mass[e.j];
      }
      change = std::max(change, std::abs(dp) / (e.m_eff * e.vn));
    }
    if (change < 1e-12) break;
  }
  en_.rebound += e_reb;
  const double dt = dt_;
  for (std::size_t k = 0; k < n; ++k) { // the impulses act as forces P/Δt over this step
    const ReboundEvent& e = fp_.rebound_all[k];
    if (fp_.rebound_p[k] == 0.0) continue;
    const double Fx = fp_.rebound_p[k] / dt * e.nx, Fz = fp_.rebound_p[k] / dt * e.nz;
    p_.fx[e.i] += Fx;
    p_.fz[e.i] += Fz;
    if (e.j != ReboundEvent::kBoundary) {
      p_.fx[e.j] -= Fx;
      p_.fz[e.j] -= Fz;
      continue;
    }
    Boundary& B = bd_.list[static_cast<std::size_t>(e.boundary)];
    B.reaction_x -= Fx;
    B.reaction_z -= Fz;
    if (B.structure >= 0) {
      StructureState& st = bd_.structures[static_cast<std::size_t>(B.structure)];
      st.soil_fx -= Fx;
      st.soil_fz -= Fz;
      st.soil_moment += e.rx * (-Fz) - e.rz * (-Fx); // (q − P) × (−F)
    }
  }
}

} // namespace demfem::dem
