#include "demfem/output/contract.hpp"
#include "probe_kinds.hpp"

namespace demfem::output::detail {

StructuresProbe::StructuresProbe(std::vector<std::string> names, bool load_histories)
    : Probe(std::string(file::structures), 0.0), names_(std::move(names)),
      load_histories_(load_histories) {}

std::vector<std::string> StructuresProbe::columns() const {
  std::vector<std::string> c{heading(col::time)};
  for (const auto& s : names_) {
    for (const Column& q : kStructureColumns) c.push_back(heading(s, q));
    if (load_histories_)
      for (const Column& q : kStructureLoadColumns) c.push_back(heading(s, q));
  }
  return c;
}

void StructuresProbe::fill(ProbeSource& source, std::vector<double>& v) {
  for (std::size_t k = 0; k < names_.size(); ++k) {
    const StructureState s = source.structure(k);
    v.insert(v.end(), {s.settlement, s.rotation, s.moment, s.force_x, s.force_z, s.applied_moment,
                       s.displacement_x});
    if (load_histories_) v.insert(v.end(), {s.applied_force_x, s.applied_force_z});
  }
}

} // namespace demfem::output::detail
