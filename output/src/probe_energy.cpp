#include "demfem/output/contract.hpp"
#include "probe_kinds.hpp"

namespace demfem::output::detail {

EnergyProbe::EnergyProbe(double interval) : Probe(std::string(file::energy), interval) {}

std::vector<std::string> EnergyProbe::columns() const {
  std::vector<std::string> c{heading(col::time)};
  for (const Column& q : kEnergyColumns) c.push_back(heading(q));
  return c;
}

void EnergyProbe::fill(ProbeSource& source, std::vector<double>& v) {
  const EnergyTerms b = source.energy();
  v.insert(v.end(),
           {b.kinetic, b.rotational, b.potential, b.spring_normal, b.spring_shear, b.friction,
            b.damping, b.rebound, b.external_work, b.gravity_work, b.imbalance, b.left_scene});
}

} // namespace demfem::output::detail
