#include "demfem/output/contract.hpp"
#include "probe_kinds.hpp"

namespace demfem::output::detail {

LociProbe::LociProbe(std::vector<std::uint32_t> ids, double interval)
    : Probe(std::string(file::loci), interval), ids_(std::move(ids)) {}

std::vector<std::string> LociProbe::columns() const {
  std::vector<std::string> c{heading(col::time)};
  for (const auto id : ids_) {
    c.push_back(heading(locus_owner(id), col::locus_x));
    c.push_back(heading(locus_owner(id), col::locus_z));
  }
  return c;
}

void LociProbe::fill(ProbeSource& source, std::vector<double>& v) {
  for (const auto id : ids_) {
    const scene::Vec2 p = source.position(id);
    v.push_back(p.x);
    v.push_back(p.z);
  }
}

} // namespace demfem::output::detail
