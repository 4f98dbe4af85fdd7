// Engine: checkpoint / resume — the versioned state blob and the contact-history blob.
#include "demfem/dem/engine.hpp"

#include <algorithm>
#include <stdexcept>

#include <fmt/format.h>

#include "state_bytes.hpp"

#include "engine_internal.hpp"

namespace demfem::dem {

using namespace detail;

// ---- checkpoint / resume -----------------------------------------------------------------------

namespace {
constexpr std::uint32_t kStateMagic = 0x44454d53;   // "DEMS"
constexpr std::uint32_t kStateVersion = 2;          // 2: the energy removed particles carried out
constexpr std::uint32_t kHistoryMagic = 0x44454d48; // "DEMH"
constexpr std::uint32_t kExtraMagic = 0x44454d58;   // "DEMX": the extra history

void write_hist(detail::ByteWriter& w, const std::vector<ContactHistory>& h) {
  w.value(static_cast<std::uint64_t>(h.size()));
  for (const auto& c : h) { // field by field: no padding bytes in the file
    w.value(c.ft);
    w.value(c.fn);
    w.value(c.flags);
  }
}
void read_hist(detail::ByteReader& r, std::vector<ContactHistory>& h) {
  const auto n = r.value<std::uint64_t>();
  h.clear();
  for (std::uint64_t k = 0; k < n; ++k) {
    ContactHistory c;
    r.value(c.ft);
    r.value(c.fn);
    r.value(c.flags);
    h.push_back(c);
  }
}
} // namespace

std::vector<std::byte> Engine::save_state() const {
  detail::ByteWriter w;
  w.value(kStateMagic);
  w.value(kStateVersion);
  w.value(static_cast<std::uint64_t>(p_.size()));
  w.value(static_cast<std::uint64_t>(bd_.list.size()));
  w.value(static_cast<std::uint64_t>(bd_.structures.size()));
  w.value(static_cast<std::uint64_t>(bd_.features.size()));
  w.value(dt_);
  w.value(time_);
  w.value(stats_.steps);
  w.value(stats_.neighbour_rebuilds);
  w.value(stats_.reorders);
  w.value(stats_.structure_updates);
  w.value(static_cast<std::uint64_t>(stats_.pair_entries));
  w.value(static_cast<std::uint64_t>(stats_.boundary_entries));
  w.value(static_cast<std::uint64_t>(config_.materials.size()));
  for (const auto& m : config_.materials) {
    w.value(m.mu_s);
    w.value(m.mu_d);
  }
  for (const auto& b : bd_.list) {
    w.value(static_cast<std::uint8_t>(b.active ? 1 : 0));
    w.value(b.reaction_x);
    w.value(b.reaction_z);
  }
  w.vec(bd_.vx);
  w.vec(bd_.vz);
  w.vec(nl_.bvx_ref);
  w.vec(nl_.bvz_ref);
  for (const auto& st : bd_.structures)
    for (double v : {st.ux, st.uz, st.rot, st.vx, st.vz, st.omega, st.soil_fx, st.soil_fz,
                     st.soil_moment, st.applied_fx, st.applied_fz, st.applied_moment})
      w.value(v);
  w.vec(nl_.start);
  w.vec(nl_.j);
  write_hist(w, nl_.hist);
  w.vec(nl_.bnd_i);
  w.vec(nl_.bnd_f);
  write_hist(w, nl_.bnd_hist);
  if (xh_ > 0) { // the sub-models' extra history (a law without any writes nothing)
    w.vec(nl_.xh);
    w.vec(nl_.bnd_xh);
  }
  w.vec(nl_.x_ref);
  w.vec(nl_.z_ref);
  for (double v : {nl_.skin, r_min_, r_max_, m_min_}) w.value(v);
  w.value(static_cast<std::uint8_t>(nl_.need_rebuild ? 1 : 0));
  w.value(nl_.rebuilds_since_reorder);
  w.value(next_id_);
  for (double v : {en_.friction, en_.damping, en_.rebound, en_.external, en_.normal, en_.shear,
                   en_.pe_ref, en_.left, en_.pe_left})
    w.value(v);
  w.value(static_cast<std::uint8_t>(en_.pe_ref_set ? 1 : 0));
  return std::move(w.buffer());
}

void Engine::restore_state(Particles particles, std::span<const std::byte> state) {
  detail::ByteReader r(state);
  if (r.value<std::uint32_t>() != kStateMagic) detail::ByteReader::fail("not an engine state");
  if (const auto v = r.value<std::uint32_t>(); v != kStateVersion)
    detail::ByteReader::fail(fmt::format("unsupported version {}", v));
  const auto n = r.value<std::uint64_t>();
  if (n != particles.size())
    detail::ByteReader::fail(
        fmt::format("{} particles in the state, {} in the arrays", n, particles.size()));
  if (r.value<std::uint64_t>() != bd_.list.size() ||
      r.value<std::uint64_t>() != bd_.structures.size() ||
      r.value<std::uint64_t>() != bd_.features.size())
    detail::ByteReader::fail("walls or structures differ from the scene's");
  p_ = std::move(particles);
  r.value(dt_);
  r.value(time_);
  r.value(stats_.steps);
  r.value(stats_.neighbour_rebuilds);
  r.value(stats_.reorders);
  r.value(stats_.structure_updates);
  stats_.pair_entries = r.value<std::uint64_t>();
  stats_.boundary_entries = r.value<std::uint64_t>();
  config_.materials.resize(r.value<std::uint64_t>());
  for (auto& m : config_.materials) {
    r.value(m.mu_s);
    r.value(m.mu_d);
  }
  for (auto& b : bd_.list) {
    b.active = r.value<std::uint8_t>() != 0;
    r.value(b.reaction_x);
    r.value(b.reaction_z);
  }
  r.vec(bd_.vx);
  r.vec(bd_.vz);
  r.vec(nl_.bvx_ref);
  r.vec(nl_.bvz_ref);
  if (bd_.vx.size() != bd_.vx0.size()) detail::ByteReader::fail("boundary vertex count differs");
  for (auto& st : bd_.structures)
    for (double* v : {&st.ux, &st.uz, &st.rot, &st.vx, &st.vz, &st.omega, &st.soil_fx, &st.soil_fz,
                      &st.soil_moment, &st.applied_fx, &st.applied_fz, &st.applied_moment})
      r.value(*v);
  r.vec(nl_.start);
  r.vec(nl_.j);
  read_hist(r, nl_.hist);
  r.vec(nl_.bnd_i);
  r.vec(nl_.bnd_f);
  read_hist(r, nl_.bnd_hist);
  if (xh_ > 0) {
    r.vec(nl_.xh);
    r.vec(nl_.bnd_xh);
  } else {
    nl_.xh.clear();
    nl_.bnd_xh.clear();
  }
  r.vec(nl_.x_ref);
  r.vec(nl_.z_ref);
  for (double* v : {&nl_.skin, &r_min_, &r_max_, &m_min_}) r.value(*v);
  nl_.need_rebuild = r.value<std::uint8_t>() != 0;
  r.value(nl_.rebuilds_since_reorder);
  r.value(next_id_);
  for (double* v : {&en_.friction, &en_.damping, &en_.rebound, &en_.external, &en_.normal,
                    &en_.shear, &en_.pe_ref, &en_.left, &en_.pe_left})
    r.value(*v);
  en_.pe_ref_set = r.value<std::uint8_t>() != 0;
  if (!r.at_end()) detail::ByteReader::fail("trailing bytes");
  if (nl_.j.size() != nl_.hist.size() || nl_.bnd_i.size() != nl_.bnd_f.size() ||
      nl_.bnd_i.size() != nl_.bnd_hist.size() ||
      (!nl_.start.empty() && nl_.start.size() != n + 1) || nl_.xh.size() != nl_.hist.size() * xh_ ||
      nl_.bnd_xh.size() != nl_.bnd_hist.size() * xh_)
    detail::ByteReader::fail("inconsistent neighbour lists");
  set_owners();
  friction_dirty_ = true;
  nl_.disp_valid = false;
  failure_.clear();
}

std::vector<std::byte> Engine::save_contact_history(bool with_boundaries) const {
  // Active entries only, keyed by stable particle ids: (id_i, id_j, history), then
  // (id_i, feature, history).
  detail::ByteWriter w;
  w.value(kHistoryMagic);
  std::vector<std::uint32_t> a, b;
  std::vector<ContactHistory> h;
  std::vector<double> xp, xb; // the extra history of the pairs and boundary contacts written
  auto extra = [&](std::vector<double>& to, const std::vector<double>& from, std::size_t k) {
    to.insert(to.end(), from.begin() + static_cast<std::ptrdiff_t>(k * xh_),
              from.begin() + static_cast<std::ptrdiff_t>((k + 1) * xh_));
  };
  for (std::size_t i = 0; i + 1 < nl_.start.size(); ++i)
    for (std::uint32_t k = nl_.start[i]; k < nl_.start[i + 1]; ++k)
      if (nl_.hist[k].flags != 0) {
        a.push_back(p_.id[i]);
        b.push_back(p_.id[nl_.j[k]]);
        h.push_back(nl_.hist[k]);
        extra(xp, nl_.xh, k);
      }
  w.vec(a);
  w.vec(b);
  write_hist(w, h);
  a.clear();
  b.clear();
  h.clear();
  for (std::size_t k = 0; with_boundaries && k < nl_.bnd_i.size(); ++k)
    if (nl_.bnd_hist[k].flags != 0) {
      a.push_back(p_.id[nl_.bnd_i[k]]);
      b.push_back(nl_.bnd_f[k]);
      h.push_back(nl_.bnd_hist[k]);
      extra(xb, nl_.bnd_xh, k);
    }
  w.vec(a);
  w.vec(b);
  write_hist(w, h);
  if (xh_ > 0) { // a law with extra history: a tagged section (a blob without one reads as zeros)
    w.value(kExtraMagic);
    w.value(static_cast<std::uint64_t>(xh_));
    w.vec(xp);
    w.vec(xb);
  }
  return std::move(w.buffer());
}

void Engine::load_contact_history(std::span<const std::byte> blob) {
  detail::ByteReader r(blob);
  if (r.value<std::uint32_t>() != kHistoryMagic) detail::ByteReader::fail("not a contact history");
  std::vector<std::uint32_t> a, b, c, d;
  std::vector<ContactHistory> h, hb;
  r.vec(a);
  r.vec(b);
  read_hist(r, h);
  r.vec(c);
  r.vec(d);
  read_hist(r, hb);
  if (a.size() != b.size() || a.size() != h.size() || c.size() != d.size() || c.size() != hb.size())
    detail::ByteReader::fail("inconsistent contact history");
  // The extra history, when the blob has it for this law's width; else (a packing deposited
  // without the sub-model that keeps it) zeros.
  std::vector<double> xp(h.size() * xh_, 0.0), xb(hb.size() * xh_, 0.0);
  if (!r.at_end()) {
    if (r.value<std::uint32_t>() != kExtraMagic) detail::ByteReader::fail("trailing bytes");
    const auto width = r.value<std::uint64_t>();
    std::vector<double> fp, fb;
    r.vec(fp);
    r.vec(fb);
    if (fp.size() != h.size() * width || fb.size() != hb.size() * width)
      detail::ByteReader::fail("inconsistent extra contact history");
    if (width == xh_) {
      xp.swap(fp);
      xb.swap(fb);
    }
  }
  const std::size_t n = p_.size();
  std::uint32_t max_id = 0;
  for (std::size_t i = 0; i < n; ++i) max_id = std::max(max_id, p_.id[i]);
  std::vector<std::uint32_t> index(static_cast<std::size_t>(max_id) + 1, ~0u);
  for (std::size_t i = 0; i < n; ++i) index[p_.id[i]] = static_cast<std::uint32_t>(i);
  auto idx = [&](std::uint32_t id) { return id <= max_id ? index[id] : ~0u; };
  // Same layout reorder() leaves: a CSR list of the history entries, merged by rebuild().
  std::vector<std::uint32_t> pi, pj;
  std::vector<ContactHistory> ph;
  std::vector<double> px;
  for (std::size_t k = 0; k < a.size(); ++k) {
    std::uint32_t u = idx(a[k]), v = idx(b[k]);
    if (u == ~0u || v == ~0u || u == v) continue;
    // Swapping the owner flips n and t: f_t is unchanged. A rolling moment on the owner is
    // against ω_owner − ω_partner: swapped, it changes sign.
    const bool swapped = u > v;
    if (swapped) std::swap(u, v);
    pi.push_back(u);
    pj.push_back(v);
    ph.push_back(h[k]);
    for (std::size_t q = 0; q < xh_; ++q) px.push_back(xp[k * xh_ + q]);
    if (swapped && xh_ > 0) flip_owner(px.data() + px.size() - xh_);
  }
  // Store as a CSR list holding only the active pairs; rebuild() merges it.
  store_pairs_csr(n, pi, pj, ph, px, xh_, nl_.start, nl_.j, nl_.hist, nl_.xh);
  set_owners();
  nl_.bnd_i.clear();
  nl_.bnd_f.clear();
  nl_.bnd_hist.clear();
  nl_.bnd_xh.clear();
  std::vector<std::uint32_t> o;
  for (std::size_t k = 0; k < c.size(); ++k)
    if (idx(c[k]) != ~0u && d[k] < bd_.features.size()) o.push_back(static_cast<std::uint32_t>(k));
  std::sort(o.begin(), o.end(), [&](std::uint32_t x, std::uint32_t y) {
    return idx(c[x]) != idx(c[y]) ? idx(c[x]) < idx(c[y]) : d[x] < d[y];
  });
  for (auto k : o) {
    nl_.bnd_i.push_back(idx(c[k]));
    nl_.bnd_f.push_back(d[k]);
    nl_.bnd_hist.push_back(hb[k]);
    for (std::size_t q = 0; q < xh_; ++q) nl_.bnd_xh.push_back(xb[k * xh_ + q]);
  }
  nl_.need_rebuild = true;
}

} // namespace demfem::dem
