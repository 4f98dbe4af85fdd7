#include "hooks.hpp"

namespace demfem::dem::run_detail {

Checkpoints::Checkpoints(const scene::Scene& scene, std::filesystem::path path, bool resuming,
                         LoopState& ls)
    : scene_(scene), path_(std::move(path)), interval_(scene.output.checkpoint_interval), ls_(ls) {
  if (!resuming) ls_.next_ckpt = interval_;
}

void Checkpoints::at(Engine& e, output::ProbeSet& probes, const Events& events) {
  if (interval_ > 0.0 && e.time() >= ls_.next_ckpt - 0.5 * e.dt()) {
    ls_.next_ckpt += interval_;
    write(e, probes, events);
  }
}

void Checkpoints::write(Engine& e, output::ProbeSet& probes, const Events& events) {
  probes.flush(); // a resume keeps the rows before the checkpoint's time
  ls_.next_event = events.next();
  ls_.probes = probes.state();
  io::CheckpointMeta meta;
  meta.time = e.time();
  meta.step = e.stats().steps;
  meta.dt = e.dt();
  meta.label = scene_.label();
  io::write_checkpoint(path_, e.particles(), meta, pack_state(e, ls_));
}

void Checkpoints::write_final(Engine& e, const scene::Scene& scene,
                              const std::filesystem::path& path) {
  io::CheckpointMeta meta;
  meta.time = e.time();
  meta.step = e.stats().steps;
  meta.dt = e.dt();
  meta.label = scene.label();
  io::write_checkpoint(path, e.particles(), meta);
}

} // namespace demfem::dem::run_detail
