#include "demfem/output/contract.hpp"
#include "hooks.hpp"

namespace demfem::dem::run_detail {

namespace file = output::file;

Snapshots::Snapshots(const scene::Scene& scene, std::filesystem::path out, bool resuming,
                     double keep_until, LoopState& ls)
    : scene_(scene), out_(std::move(out)), resuming_(resuming), keep_until_(keep_until),
      interval_(scene.output.interval > 0.0 ? scene.output.interval : scene.info.duration),
      ls_(ls) {}

void Snapshots::at(Engine& e) {
  if (e.time() >= ls_.next_snap - 0.5 * e.dt()) {
    write(e);
    ls_.next_snap += interval_;
  }
}

// Particles, boundaries and force chains of one time, numbered together; a resumed run keeps the
// collections' entries before the checkpoint's time.
void Snapshots::write(Engine& e) {
  if (!scene_.output.vtk) return;
  const auto vtk = out_ / output::dir::vtk;
  if (!particles_) {
    std::filesystem::create_directories(vtk);
    if (resuming_) {
      particles_.emplace(io::PvdCollection::resume(out_ / file::particles_pvd, keep_until_));
      bounds_.emplace(io::PvdCollection::resume(out_ / file::boundaries_pvd, keep_until_));
      if (scene_.output.force_chains)
        chains_.emplace(io::PvdCollection::resume(out_ / file::force_chains_pvd, keep_until_));
    } else {
      particles_.emplace(out_ / file::particles_pvd);
      bounds_.emplace(out_ / file::boundaries_pvd);
      if (scene_.output.force_chains) chains_.emplace(out_ / file::force_chains_pvd);
    }
  }
  const auto compression = scene_.output.vtk_compression;
  const std::int64_t snap = ls_.snap;
  const auto pf = vtk / io::numbered_file_name(std::string(file::particles_stem), snap, "vtp");
  io::write_particles_vtp(pf, e.particles(), compression);
  particles_->add(e.time(), pf);
  e.boundary_views(bviews_);
  const auto bf = vtk / io::numbered_file_name(std::string(file::boundaries_stem), snap, "vtp");
  io::write_boundaries_vtp(bf, bviews_, compression);
  bounds_->add(e.time(), bf);
  if (chains_) {
    e.contacts(contacts_);
    const auto cf = vtk / io::numbered_file_name(std::string(file::force_chains_stem), snap, "vtp");
    io::write_force_chains_vtp(cf, e.particles(), contacts_, compression);
    chains_->add(e.time(), cf);
  }
  ++ls_.snap;
}

} // namespace demfem::dem::run_detail
