#include <fmt/format.h>

#include "../state_bytes.hpp"
#include "hooks.hpp"

namespace demfem::dem::run_detail {
namespace {
// Run-loop state stored next to the engine state in a checkpoint's extra blob. Version 2 adds the
// schedules of the probes with an interval of their own; a run without such probes writes
// version 1.
constexpr std::uint32_t kRunMagic = 0x44454d52; // "DEMR"
constexpr std::uint32_t kRunVersionShared = 1;  // every probe on output.probe_interval
constexpr std::uint32_t kRunVersionOwn = 2;     // + the probes' own schedules
} // namespace

std::vector<std::byte> pack_state(const Engine& e, const LoopState& s) {
  detail::ByteWriter w;
  w.value(kRunMagic);
  const bool own = !s.probes.next_own.empty();
  w.value(own ? kRunVersionOwn : kRunVersionShared);
  const auto es = e.save_state();
  w.bytes(es);
  w.value(s.next_event);
  w.value(s.probes.next_base);
  w.value(s.next_snap);
  w.value(s.next_ckpt);
  w.value(s.snap);
  w.value(s.e0);
  w.value(s.energy_scale);
  w.value(static_cast<std::uint8_t>(s.e0_set ? 1 : 0));
  w.vec(s.probes.traced);
  if (own) w.vec(s.probes.next_own);
  return std::move(w.buffer());
}

LoopState unpack_state(Engine& e, Particles particles, std::span<const std::byte> extra) {
  detail::ByteReader r(extra);
  if (r.value<std::uint32_t>() != kRunMagic) detail::ByteReader::fail("not a DEM run checkpoint");
  const auto version = r.value<std::uint32_t>();
  if (version != kRunVersionShared && version != kRunVersionOwn)
    detail::ByteReader::fail(fmt::format("unsupported run-state version {}", version));
  e.restore_state(std::move(particles), r.bytes());
  LoopState s;
  r.value(s.next_event);
  r.value(s.probes.next_base);
  r.value(s.next_snap);
  r.value(s.next_ckpt);
  r.value(s.snap);
  r.value(s.e0);
  r.value(s.energy_scale);
  s.e0_set = r.value<std::uint8_t>() != 0;
  r.vec(s.probes.traced);
  if (version == kRunVersionOwn) r.vec(s.probes.next_own);
  if (!r.at_end()) detail::ByteReader::fail("trailing bytes in the run state");
  return s;
}

} // namespace demfem::dem::run_detail
