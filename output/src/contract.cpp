#include "demfem/output/contract.hpp"

#include <cctype>

#include <fmt/format.h>

namespace demfem::output {

std::string heading(const Column& c) {
  return c.unit.empty() ? std::string(c.name) : fmt::format("{} [{}]", c.name, c.unit);
}

std::string heading(std::string_view owner, const Column& c) {
  return fmt::format("{}.{}", owner, heading(c));
}

std::string key(std::string_view owner, const Column& c) {
  return fmt::format("{}.{}", owner, c.name);
}

std::string file::pressure(std::string_view target) {
  return fmt::format("pressure_{}.csv", target);
}

std::string bin_heading(std::string_view owner, int k, const Column& c) {
  return fmt::format("{}.{}{} [{}]", owner, c.name, k, c.unit);
}

bool is_bin_heading(std::string_view name, std::string* owner, int* bin) {
  const auto p = name.find(".bin");
  if (p == std::string_view::npos) return false;
  std::size_t q = p + 4;
  int k = 0;
  bool digits = false;
  while (q < name.size() && std::isdigit(static_cast<unsigned char>(name[q]))) {
    k = 10 * k + (name[q] - '0');
    ++q;
    digits = true;
  }
  if (!digits || (q < name.size() && name[q] != ' ')) return false;
  if (owner) *owner = std::string(name.substr(0, p));
  if (bin) *bin = k;
  return true;
}

std::string locus_owner(std::uint32_t id) {
  return fmt::format("p{}", id);
}

std::span<const FileEntry> run_directory() {
  static constexpr FileEntry kFiles[] = {
      {file::energy, Writer::Dem,
       "energy budget: time, kinetic, rotational, potential, springs, dissipated terms, work, "
       "imbalance, left_scene [J]; always, at the energy probe's interval"},
      {file::structures, Writer::Both,
       "per structure: settlement, rotation, moment, force_x, force_z, applied_moment, "
       "displacement_x (the continuum adds applied_force_x, applied_force_z)"},
      {file::walls, Writer::Both,
       "per recorded wall: thrust, reaction_x, reaction_z [N] (walls with record = true, "
       "structures of kind wall or with record \"thrust\", wall-thrust probe targets)"},
      {"pressure_<target>.csv", Writer::Both,
       "pressure-profile probe: normal pressure on the target per height bin [Pa]"},
      {file::surface, Writer::Dem,
       "surface-profile probe: top of the highest particle per x bin [m]"},
      {file::loci, Writer::Dem, "loci probe: x, z of the particles nearest the given points [m]"},
      {file::coordination, Writer::Dem, "coordination probe: 2 × contacts / particles"},
      {file::packing, Writer::Dem,
       "the initial packing: porosity, void ratio, coordination number, target"},
      {file::energy_budget, Writer::Dem, "the energy budget at the end and its closure error"},
      {file::checkpoint, Writer::Dem, "the run's state, to resume it (--resume)"},
      {file::final_state, Writer::Dem, "the final particles (readable without the engine)"},
      {file::particles_pvd, Writer::Dem, "snapshot collection of vtk/particles_<k>.vtp"},
      {file::boundaries_pvd, Writer::Dem, "snapshot collection of vtk/boundaries_<k>.vtp"},
      {file::force_chains_pvd, Writer::Dem,
       "snapshot collection of vtk/force_chains_<k>.vtp (output.force_chains)"},
      {file::steps, Writer::Continuum,
       "solver statistics per step: Newton and linear iterations, cuts, residual, wall time"},
      {file::surface_profile, Writer::Continuum,
       "settlement of the soil's top at the end: x [m], settlement [m]"},
      {file::continuum_pvd, Writer::Continuum,
       "snapshot collection of continuum_<k>.pvtu (pieces continuum_<k>.<rank>.vtu)"},
      {file::log, Writer::Both, "the run's log"},
  };
  return kFiles;
}

} // namespace demfem::output
