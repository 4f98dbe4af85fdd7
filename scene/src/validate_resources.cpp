// Memory estimates against the machine's available memory, before any work: the continuum mesh
// (cells and degrees of freedom from its coarse grid) and the DEM's particles.
#include <cmath>
#include <string_view>

#include <fmt/format.h>

#include "demfem/scene/resources.hpp"
#include "demfem/scene/validate.hpp"
#include "validate_internal.hpp"

namespace demfem::scene::detail {

namespace {

void add(std::vector<Diagnostic>& diags, const std::string& file, const toml::node* n,
         const toml::table& root, std::string key, std::string message) {
  const auto& src = n ? n->source() : root.source();
  Diagnostic d;
  d.file = file;
  d.line = static_cast<int>(src.begin.line);
  d.column = static_cast<int>(src.begin.column);
  d.key = std::move(key);
  d.message = std::move(message);
  diags.push_back(std::move(d));
}

} // namespace

bool validate_memory(const Scene& sc, const Vocabulary& vocabulary, const toml::table& root,
                     const std::string& file, std::vector<Diagnostic>& diags) {
  const auto avail = available_memory();
  if (!avail) return true; // not known here (not Linux): nothing is refused for it
  bool mesh_fits = true;
  if (sc.soil.continuum && sc.uses(Solver::Continuum)) {
    const ContinuumMeshEstimate m = estimate_continuum_mesh(sc);
    if (m.bytes > avail->bytes) {
      mesh_fits = false;
      // the finest refinement that fits, for the message
      std::string fits;
      for (int r = sc.continuum.refinement - 1; r >= 0; --r) {
        Scene lower = sc;
        lower.continuum.refinement = r;
        const auto l = estimate_continuum_mesh(lower);
        if (l.bytes <= avail->bytes) {
          fits = fmt::format("; refinement {} ({:.3g} dofs) needs about {}", r, l.dofs,
                             format_bytes(l.bytes));
          break;
        }
      }
      std::string_view key = "refinement";
      for (const std::string_view k : {"refinement", "mesh_size_near", "degree"})
        if (root["continuum"][k].node()) {
          key = k;
          break;
        }
      const toml::node* n = root["continuum"][key].node();
      if (!n) n = root["continuum"].node();
      if (!n) n = root["domain"].node();
      add(diags, file, n, root, fmt::format("continuum.{}", key),
          fmt::format("the continuum mesh (refinement {}, degree {}: {} coarse cells → {:.3g} "
                      "cells, {:.3g} degrees of freedom) needs about {} of memory ({:.0f} B per "
                      "dof + {}), but this machine has {} available ({}); lower "
                      "continuum.refinement or degree, or raise mesh_size_near{}",
                      sc.continuum.refinement, sc.continuum.degree, m.coarse_cells, m.cells, m.dofs,
                      format_bytes(m.bytes), kContinuumBytesPerDof,
                      format_bytes(kContinuumBaseBytes), format_bytes(avail->bytes), avail->source,
                      fits));
    }
  }
  if (sc.soil.dem && sc.uses(Solver::Dem)) {
    const Estimates e = estimate(sc, vocabulary);
    // above the fixed ceiling the scene check already refuses it (validate.cpp)
    if (e.memory_bytes <= kMaxMemoryBytes && e.memory_bytes > avail->bytes) {
      const bool from_file = !sc.soil.dem->particles_file.empty();
      const toml::node* n = root["soil"]["dem"][from_file ? "particles_file" : "count"].node();
      if (!n) n = root["soil"]["dem"].node();
      add(diags, file, n, root, from_file ? "soil.dem.particles_file" : "soil.dem.count",
          fmt::format("{:.0f} particles need about {} of memory ({:.0f} B each: state, neighbour "
                      "lists, contacts), but this machine has {} available ({}); at most about "
                      "{:.0f} particles fit",
                      e.memory_bytes / kBytesPerParticle, format_bytes(e.memory_bytes),
                      kBytesPerParticle, format_bytes(avail->bytes), avail->source,
                      std::floor(avail->bytes / kBytesPerParticle)));
    }
  }
  return mesh_fits;
}

} // namespace demfem::scene::detail
