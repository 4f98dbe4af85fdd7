// Engine: Verlet neighbour list — displacement check, cache-friendly reorder, cell-grid
// rebuild with the contact history carried over.
#include "demfem/dem/engine.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "engine_internal.hpp"

namespace demfem::dem {

using namespace detail;

// ---- neighbour search ---------------------------------------------------------------------------

void Engine::update_boundary_vertices() {
  for (auto& st : bd_.structures) {
    if (!(st.ux != 0.0 || st.uz != 0.0 || st.rot != 0.0 || st.vx != 0.0 || st.vz != 0.0 ||
          st.omega != 0.0))
      continue;
    const double c = std::cos(st.rot), s = std::sin(st.rot);
    const double px = st.px0 + st.ux, pz = st.pz0 + st.uz;
    for (std::uint32_t k = st.first_vertex; k < st.first_vertex + st.vertex_count; ++k) {
      const double lx = bd_.vx0[k] - st.px0, lz = bd_.vz0[k] - st.pz0;
      bd_.vx[k] = px + c * lx - s * lz; // rigid rotation about the pivot
      bd_.vz[k] = pz + s * lx + c * lz;
    }
  }
}

void Engine::set_owners() {
  ++nl_.version; // the pair loop's parts are recomputed for this list
  nl_.owner.resize(nl_.j.size());
  for (std::size_t i = 0; i + 1 < nl_.start.size(); ++i)
    std::fill(nl_.owner.begin() + nl_.start[i], nl_.owner.begin() + nl_.start[i + 1],
              static_cast<std::uint32_t>(i));
}

namespace {

using detail::Top2;
#pragma omp declare reduction(top2:Top2 : omp_out.merge(omp_in))

} // namespace

void Engine::check_rebuild() {
  if (nl_.need_rebuild || nl_.x_ref.size() != p_.size()) {
    rebuild();
    return;
  }
  const std::size_t n = p_.size();
  const double* x = p_.x.data();
  const double* z = p_.z.data();
  const double* xr = nl_.x_ref.data();
  const double* zr = nl_.z_ref.data();
  Top2 top;
  const int A = team_size();
  if (nl_.disp_valid) { // computed by the integration that moved them (integrate_range)
    top.a = nl_.disp_a;
    top.b = nl_.disp_b;
  } else if (A > 1) {
#pragma omp parallel for num_threads(A) schedule(static) reduction(top2 : top)
    for (std::size_t i = 0; i < n; ++i) {
      const double dx = x[i] - xr[i], dz = z[i] - zr[i];
      top.add(dx * dx + dz * dz);
    }
  } else {
    for (std::size_t i = 0; i < n; ++i) {
      const double dx = x[i] - xr[i], dz = z[i] - zr[i];
      top.add(dx * dx + dz * dz);
    }
  }
  nl_.disp_valid = false;
  if (past_skin(top.a, top.b)) rebuild();
}

bool Engine::past_skin(double disp2_a, double disp2_b) const {
  double b2 = 0.0;
  for (std::size_t k = 0; k < bd_.vx.size(); ++k) {
    const double dx = bd_.vx[k] - nl_.bvx_ref[k], dz = bd_.vz[k] - nl_.bvz_ref[k];
    b2 = std::max(b2, dx * dx + dz * dz);
  }
  // A pair left out of the list was at least `skin` apart (gap) at the rebuild, and its gap has
  // shrunk by at most the sum of the two displacements: by at most d1 + d2 for two particles (the
  // two largest displacements) and d1 + d_b for a particle and a wall or structure (d_b: the
  // largest boundary vertex displacement; a rigid outline's points move by at most its vertices'
  // largest). Verlet's test d1 > skin/2 is the special case d2 = d1; with one fast particle among
  // slow ones (a grain thrown off a shaken surface) this one rebuilds about half as often.
  const double d1 = std::sqrt(disp2_a);
  return d1 + std::max(std::sqrt(disp2_b), std::sqrt(b2)) > nl_.skin;
}

bool Engine::rebuild_pending() const {
  return nl_.need_rebuild || nl_.x_ref.size() != p_.size() || !nl_.disp_valid ||
         past_skin(nl_.disp_a, nl_.disp_b);
}

void Engine::reorder() {
  const std::size_t n = p_.size();
  if (n < 2) return;
  double xmin = std::numeric_limits<double>::infinity(), zmin = xmin;
  double xmax = -xmin, zmax = -xmin;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(p_.x[i]) || !std::isfinite(p_.z[i])) continue;
    xmin = std::min(xmin, p_.x[i]);
    zmin = std::min(zmin, p_.z[i]);
    xmax = std::max(xmax, p_.x[i]);
    zmax = std::max(zmax, p_.z[i]);
  }
  if (!(xmin <= xmax)) return; // no finite position
  // Columns across the longer side: the column index is the major key, the cell along the
  // column the minor one (a particle's neighbours are then within ~2 columns of it in memory).
  const bool morton_order = config_.particle_order == EngineConfig::ParticleOrder::morton;
  const bool x_major = xmax - xmin >= zmax - zmin;
  const double h = 2.0 * r_max_;
  std::vector<std::uint64_t> key(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(p_.x[i]) || !std::isfinite(p_.z[i])) {
      key[i] = ~0ull;
      continue;
    }
    const auto cx = static_cast<std::uint32_t>(std::min((p_.x[i] - xmin) / h, 1.0e9));
    const auto cz = static_cast<std::uint32_t>(std::min((p_.z[i] - zmin) / h, 1.0e9));
    key[i] = morton_order ? morton(cx, cz)
             : x_major    ? (static_cast<std::uint64_t>(cx) << 32) | cz
                          : (static_cast<std::uint64_t>(cz) << 32) | cx;
  }
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });
  // Old index → new index, to carry the contact history over.
  std::vector<std::uint32_t> new_of(n);
  for (std::size_t k = 0; k < n; ++k) new_of[order[k]] = static_cast<std::uint32_t>(k);
  // Re-key the pair history: (owner, partner) → new indices, owner < partner.
  std::vector<std::uint32_t> pi, pj;
  std::vector<ContactHistory> ph;
  std::vector<double> px;
  for (std::size_t i = 0; i + 1 < nl_.start.size(); ++i)
    for (std::uint32_t k = nl_.start[i]; k < nl_.start[i + 1]; ++k)
      if (nl_.hist[k].flags != 0) {
        // Swapping the owner flips both n and t, so f_t (force on the owner along t) is unchanged;
        // the extra history may change (a rolling moment on the owner changes sign).
        std::uint32_t a = new_of[i], b = new_of[nl_.j[k]];
        const bool swapped = a > b;
        if (swapped) std::swap(a, b);
        pi.push_back(a);
        pj.push_back(b);
        ph.push_back(nl_.hist[k]);
        px.insert(px.end(), nl_.xh.begin() + static_cast<std::ptrdiff_t>(k * xh_),
                  nl_.xh.begin() + static_cast<std::ptrdiff_t>((k + 1) * xh_));
        if (swapped && xh_ > 0) flip_owner(px.data() + px.size() - xh_);
      }
  // Store as a CSR list holding only the active pairs; rebuild() merges it.
  store_pairs_csr(n, pi, pj, ph, px, xh_, nl_.start, nl_.j, nl_.hist, nl_.xh);
  set_owners();
  for (auto& bi : nl_.bnd_i) bi = new_of[bi];
  {
    std::vector<std::uint32_t> o(nl_.bnd_i.size());
    std::iota(o.begin(), o.end(), 0u);
    std::sort(o.begin(), o.end(), [&](std::uint32_t a, std::uint32_t b) {
      return nl_.bnd_i[a] != nl_.bnd_i[b] ? nl_.bnd_i[a] < nl_.bnd_i[b]
                                          : nl_.bnd_f[a] < nl_.bnd_f[b];
    });
    permute(nl_.bnd_i, o);
    permute(nl_.bnd_f, o);
    permute(nl_.bnd_hist, o);
    permute(nl_.bnd_xh, o, xh_);
  }
  permute(p_.x, order);
  permute(p_.z, order);
  permute(p_.phi, order);
  permute(p_.vx, order);
  permute(p_.vz, order);
  permute(p_.omega, order);
  permute(p_.fx, order);
  permute(p_.fz, order);
  permute(p_.torque, order);
  permute(p_.radius, order);
  permute(p_.mass, order);
  permute(p_.inv_mass, order);
  permute(p_.inv_inertia, order);
  permute(p_.id, order);
  permute(p_.material, order);
  permute(p_.flags, order);
  ++stats_.reorders;
}

// Boundary candidates of the particles i0 … i1 − 1: every (particle, active feature) pair within
// reach, in (particle, feature) order.
void Engine::boundary_candidates(std::size_t i0, std::size_t i1, std::vector<std::uint32_t>& ni_out,
                                 std::vector<std::uint32_t>& nf_out) const {
  // Appended to vectors of this thread's own, as the pair search does (rebuild()): the parts'
  // vectors share cache lines.
  std::vector<std::uint32_t> ni, nf;
  ni.swap(ni_out);
  nf.swap(nf_out);
  ni.clear();
  nf.clear();
  // Each active feature's bounding box, widened by the largest reach (r_max + skin) and a
  // relative margin far above round-off: a particle outside it is farther from the feature than
  // its reach, so the exact test below would reject it too (the same candidates, without the
  // projection and its division for most (particle, feature) pairs).
  struct Box {
    std::uint32_t f;
    double x0, x1, z0, z1;
  };
  std::vector<Box> boxes;
  boxes.reserve(bd_.features.size());
  const double grow = (r_max_ + nl_.skin) * (1.0 + 1e-9) + 1e-12;
  for (std::size_t f = 0; f < bd_.features.size(); ++f) {
    const Feature& F = bd_.features[f];
    if (!bd_.list[F.boundary].active) continue;
    boxes.push_back({static_cast<std::uint32_t>(f), std::min(bd_.vx[F.v0], bd_.vx[F.v1]) - grow,
                     std::max(bd_.vx[F.v0], bd_.vx[F.v1]) + grow,
                     std::min(bd_.vz[F.v0], bd_.vz[F.v1]) - grow,
                     std::max(bd_.vz[F.v0], bd_.vz[F.v1]) + grow});
  }
  for (std::size_t i = i0; i < i1; ++i) {
    if (p_.flags[i] & kFlagRemoved) continue;
    const double reach = p_.radius[i] + nl_.skin;
    const double px = p_.x[i], pz = p_.z[i];
    for (const Box& bx : boxes) {
      if (px < bx.x0 || px > bx.x1 || pz < bx.z0 || pz > bx.z1) continue;
      const std::size_t f = bx.f;
      const Feature& F = bd_.features[f];
      double d2;
      if (F.v0 == F.v1) {
        const double dx = px - bd_.vx[F.v0], dz = pz - bd_.vz[F.v0];
        d2 = dx * dx + dz * dz;
      } else {
        const double ax = bd_.vx[F.v0], az = bd_.vz[F.v0];
        const double ex = bd_.vx[F.v1] - ax, ez = bd_.vz[F.v1] - az;
        const double len2 = ex * ex + ez * ez;
        double t = len2 > 0.0 ? ((px - ax) * ex + (pz - az) * ez) / len2 : 0.0;
        t = std::clamp(t, 0.0, 1.0);
        const double dx = px - ax - t * ex, dz = pz - az - t * ez;
        d2 = dx * dx + dz * dz;
      }
      if (d2 < reach * reach) {
        ni.push_back(static_cast<std::uint32_t>(i));
        nf.push_back(static_cast<std::uint32_t>(f));
      }
    }
  }
  ni_out.swap(ni);
  nf_out.swap(nf);
}

namespace {
// Capacity for a contact history of `size` entries: the next of the steps 1024 · (9/8)^k.
std::size_t history_capacity(std::size_t size) {
  std::size_t cap = 1024;
  while (cap < size) cap = cap + cap / 8 + 1;
  return cap;
}
} // namespace

void Engine::rebuild() {
  const std::size_t n = p_.size();
  const int T = threads_in_use();
  const auto tcount = static_cast<std::size_t>(T);
  nl_.skin = config_.skin_factor * r_min_;
  // Particle order (columns or Morton) every reorder_every rebuilds, and at the first rebuild of a
  // large set (its input order may be anything; small sets keep theirs, which tests index by).
  const bool first_large = stats_.neighbour_rebuilds == 0 && n >= kReorderFirstMin;
  if (config_.reorder_every > 0 &&
      (first_large || nl_.rebuilds_since_reorder >= config_.reorder_every)) {
    reorder();
    nl_.rebuilds_since_reorder = 0;
  }
  ++nl_.rebuilds_since_reorder;
  ++stats_.neighbour_rebuilds;
  // The new list's contact history, allocated first: it takes the block the last rebuild freed
  // (the list before it), of the same capacity — a capacity rounded up to steps of 1/8, so that
  // a list a little longer than the last still fits — instead of fresh pages. A first touch of a
  // page costs ≈ 11 µs on this project's VMs: 5–6 ms a rebuild of 10⁵ disks (1.5–2.5 % of a
  // race loop) went into the history's pages (bench/RESULTS.md).
  std::vector<ContactHistory> new_hist;
  new_hist.reserve(history_capacity(nl_.j.size()));

  // Remove particles that left the scene (e.g. fell through an opened wall, the paper's §3 "3D
  // loss"): under gravity, a centre more than 2 r_max below the lowest boundary point can never be
  // caught again; sideways (or without gravity) only far outside the boundaries' bounding box.
  if (!bd_.list.empty()) {
    double bx0 = bd_.vx[0], bx1 = bd_.vx[0], bz0 = bd_.vz[0], bz1 = bd_.vz[0];
    for (std::size_t k = 0; k < bd_.vx.size(); ++k) {
      bx0 = std::min(bx0, bd_.vx[k]);
      bx1 = std::max(bx1, bd_.vx[k]);
      bz0 = std::min(bz0, bd_.vz[k]);
      bz1 = std::max(bz1, bd_.vz[k]);
    }
    const double margin = std::max(bx1 - bx0, bz1 - bz0) + 10.0 * r_max_;
    const bool any_open =
        std::any_of(bd_.list.begin(), bd_.list.end(), [](const Boundary& b) { return !b.active; });
    for (std::size_t i = 0; i < n; ++i)
      if (!(p_.flags[i] & kFlagRemoved) &&
          (p_.z[i] < bz0 - (config_.gravity > 0.0 ? 2.0 * r_max_ : margin) ||
           p_.x[i] < bx0 - margin || p_.x[i] > bx1 + margin)) {
        p_.flags[i] |= any_open ? kFlagRemoved : (kFlagRemoved | kFlagLeftUnplanned);
        // what it takes out of the budget (EnergyBudget::left_scene, engine.cpp energy())
        en_.left += 0.5 * p_.mass[i] * (p_.vx[i] * p_.vx[i] + p_.vz[i] * p_.vz[i]) +
                    0.5 / p_.inv_inertia[i] * p_.omega[i] * p_.omega[i];
        en_.pe_left += p_.mass[i] * config_.gravity * p_.z[i];
        p_.vx[i] = p_.vz[i] = p_.omega[i] = 0.0;
      }
  }

  // Cell grid: cell size = largest diameter + skin, so every pair within reach sits in
  // neighbouring cells; counting sort of particles into cells.
  std::vector<std::uint32_t> new_start(n + 1, 0), new_j;
  if (n > 0) {
    double xmin = std::numeric_limits<double>::infinity(), zmin = xmin, xmax = -xmin, zmax = -xmin;
    for (std::size_t i = 0; i < n; ++i) {
      if (p_.flags[i] & kFlagRemoved) continue;
      xmin = std::min(xmin, p_.x[i]);
      xmax = std::max(xmax, p_.x[i]);
      zmin = std::min(zmin, p_.z[i]);
      zmax = std::max(zmax, p_.z[i]);
    }
    if (!(xmax >= xmin)) xmin = xmax = zmin = zmax = 0.0;
    double h = 2.0 * r_max_ + nl_.skin;
    auto ncell = [&](double ext) { return static_cast<std::size_t>(ext / h) + 1; };
    while (ncell(xmax - xmin) * ncell(zmax - zmin) > 4 * n + 64) h *= 2.0; // sparse clouds
    const std::size_t nx = ncell(xmax - xmin), nz = ncell(zmax - zmin);
    auto& cell_of = nl_.cell_of;
    auto& cell_start = nl_.cell_start;
    auto& cell_items = nl_.cell_items;
    cell_of.assign(n, 0u);
    cell_start.assign(nx * nz + 1, 0u);
    cell_items.assign(n, 0u);
    for (std::size_t i = 0; i < n; ++i) {
      if (p_.flags[i] & kFlagRemoved) {
        cell_of[i] = ~0u;
        continue;
      }
      const auto cx = std::min(static_cast<std::size_t>((p_.x[i] - xmin) / h), nx - 1);
      const auto cz = std::min(static_cast<std::size_t>((p_.z[i] - zmin) / h), nz - 1);
      cell_of[i] = static_cast<std::uint32_t>(cz * nx + cx);
      ++cell_start[cell_of[i] + 1];
    }
    for (std::size_t c = 0; c < nx * nz; ++c) cell_start[c + 1] += cell_start[c];
    {
      std::vector<std::uint32_t> fill(cell_start.begin(), cell_start.end() - 1);
      for (std::size_t i = 0; i < n; ++i)
        if (cell_of[i] != ~0u) cell_items[fill[cell_of[i]]++] = static_cast<std::uint32_t>(i);
    }
    // Candidate pairs (i < j within cut-off + skin) of the owners i0 ≤ i < i1, into `result`
    // in (owner, partner) order; new_start[i] is set relative to its start. The list grows in a
    // vector of this thread's own (moved into `result` at the end): the parts' vectors sit side
    // by side in one cache line, and two threads appending to them moved that line between the
    // cores at every particle (the search took twice as long on 2 threads as on one,
    // bench/RESULTS.md).
    auto search = [&](std::size_t i0, std::size_t i1, std::vector<std::uint32_t>& result) {
      std::vector<std::uint32_t> out;
      out.swap(result);
      out.clear();
      out.reserve((i1 - i0) * 4);
      std::vector<std::uint32_t> local;
      const double* __restrict x = p_.x.data();
      const double* __restrict z = p_.z.data();
      const double* __restrict rad = p_.radius.data();
      const double skin = nl_.skin;
      for (std::size_t i = i0; i < i1; ++i) {
        new_start[i] = static_cast<std::uint32_t>(out.size());
        if (cell_of[i] == ~0u) continue;
        const std::size_t cx = cell_of[i] % nx, cz = cell_of[i] / nx;
        const std::size_t x0 = cx > 0 ? cx - 1 : 0, x1 = std::min(cx + 1, nx - 1);
        const std::size_t z0 = cz > 0 ? cz - 1 : 0, z1 = std::min(cz + 1, nz - 1);
        const double xi = x[i], zi = z[i], ri = rad[i];
        // Candidates are kept without a branch (the count advances for j > i within reach),
        // which ≈ 24 coin-flip tests per particle would otherwise mispredict: `local` holds
        // every particle of the 3 × 3 cells.
        std::size_t cells_n = 0;
        for (std::size_t zz = z0; zz <= z1; ++zz)
          cells_n += cell_start[zz * nx + x1 + 1] - cell_start[zz * nx + x0];
        if (local.size() < cells_n) local.resize(cells_n);
        std::uint32_t* __restrict lo = local.data();
        std::size_t m = 0;
        for (std::size_t zz = z0; zz <= z1; ++zz) {
          const std::uint32_t kb = cell_start[zz * nx + x0], ke = cell_start[zz * nx + x1 + 1];
          for (std::uint32_t k = kb; k < ke; ++k) { // the row's three cells are contiguous
            const std::uint32_t j = cell_items[k];
            const double dx = xi - x[j], dz = zi - z[j];
            const double cut = ri + rad[j] + skin;
            lo[m] = j;
            m += static_cast<std::size_t>((j > i) & (dx * dx + dz * dz < cut * cut));
          }
        }
        std::sort(lo, lo + m);
        out.insert(out.end(), lo, lo + m);
      }
      result.swap(out);
    };
    if (T <= 1) {
      search(0, n, new_j);
    } else { // contiguous owner chunks, concatenated in order: the same list for any thread count
      std::vector<std::vector<std::uint32_t>> tj(tcount);
      nl_.cand_bi.resize(tcount);
      nl_.cand_bf.resize(tcount);
#pragma omp parallel num_threads(team_size())
      {
        const auto [t0, ts] = team_member();
        for (std::size_t t = t0; t < tcount; t += ts) {
          search(n * t / tcount, n * (t + 1) / tcount, tj[t]);
          boundary_candidates(n * t / tcount, n * (t + 1) / tcount, nl_.cand_bi[t], nl_.cand_bf[t]);
        }
      }
      std::size_t total = 0;
      for (const auto& v : tj) total += v.size();
      new_j.resize(total);
      std::size_t base = 0;
      for (std::size_t t = 0; t < tcount; ++t) {
        for (std::size_t i = n * t / tcount; i < n * (t + 1) / tcount; ++i)
          new_start[i] += static_cast<std::uint32_t>(base);
        std::copy(tj[t].begin(), tj[t].end(), new_j.begin() + static_cast<std::ptrdiff_t>(base));
        base += tj[t].size();
      }
    }
    new_start[n] = static_cast<std::uint32_t>(new_j.size());
  }
  // Carry the history over: both lists are sorted by (owner, partner).
  if (new_j.size() > new_hist.capacity()) new_hist.reserve(history_capacity(new_j.size()));
  new_hist.resize(new_j.size());
  std::vector<double> new_xh(new_j.size() * xh_, 0.0);
  if (nl_.start.size() == n + 1) {
#pragma omp parallel for num_threads(team_size()) schedule(static) if (T > 1)
    for (std::size_t i = 0; i < n; ++i) {
      std::uint32_t a = nl_.start[i];
      const std::uint32_t ae = nl_.start[i + 1];
      for (std::uint32_t k = new_start[i]; k < new_start[i + 1] && a < ae; ++k) {
        while (a < ae && nl_.j[a] < new_j[k]) ++a;
        if (a < ae && nl_.j[a] == new_j[k]) {
          new_hist[k] = nl_.hist[a];
          for (std::size_t q = 0; q < xh_; ++q) new_xh[k * xh_ + q] = nl_.xh[a * xh_ + q];
        }
      }
    }
  }
  nl_.start.swap(new_start);
  nl_.j.swap(new_j);
  nl_.hist.swap(new_hist);
  nl_.xh.swap(new_xh);
  set_owners();

  std::vector<std::uint32_t> ni, nf;
  if (T <= 1 || n == 0) {
    boundary_candidates(0, n, ni, nf);
  } else { // the parts' candidates (found with the pair candidates above), in part order
    std::size_t total = 0;
    for (std::size_t t = 0; t < tcount; ++t) total += nl_.cand_bi[t].size();
    ni.reserve(total);
    nf.reserve(total);
    for (std::size_t t = 0; t < tcount; ++t) {
      ni.insert(ni.end(), nl_.cand_bi[t].begin(), nl_.cand_bi[t].end());
      nf.insert(nf.end(), nl_.cand_bf[t].begin(), nl_.cand_bf[t].end());
    }
  }
  std::vector<ContactHistory> nh(ni.size());
  std::vector<double> nx(ni.size() * xh_, 0.0);
  {
    std::size_t a = 0;
    for (std::size_t k = 0; k < ni.size(); ++k) {
      while (a < nl_.bnd_i.size() &&
             (nl_.bnd_i[a] < ni[k] || (nl_.bnd_i[a] == ni[k] && nl_.bnd_f[a] < nf[k])))
        ++a;
      if (a < nl_.bnd_i.size() && nl_.bnd_i[a] == ni[k] && nl_.bnd_f[a] == nf[k]) {
        nh[k] = nl_.bnd_hist[a];
        for (std::size_t q = 0; q < xh_; ++q) nx[k * xh_ + q] = nl_.bnd_xh[a * xh_ + q];
      }
    }
  }
  nl_.bnd_i.swap(ni);
  nl_.bnd_f.swap(nf);
  nl_.bnd_hist.swap(nh);
  nl_.bnd_xh.swap(nx);

  nl_.x_ref = p_.x;
  nl_.disp_valid = false;
  nl_.z_ref = p_.z;
  nl_.bvx_ref = bd_.vx;
  nl_.bvz_ref = bd_.vz;
  stats_.pair_entries = nl_.j.size();
  stats_.boundary_entries = nl_.bnd_i.size();
  nl_.need_rebuild = false;
}

} // namespace demfem::dem
