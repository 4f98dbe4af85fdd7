#include "demfem/output/contract.hpp"
#include "probe_kinds.hpp"

namespace demfem::output::detail {

CoordinationProbe::CoordinationProbe(double interval)
    : Probe(std::string(file::coordination), interval) {}

std::vector<std::string> CoordinationProbe::columns() const {
  return {heading(col::time), heading(col::coordination)};
}

void CoordinationProbe::fill(ProbeSource& source, std::vector<double>& v) {
  v.push_back(source.coordination());
}

} // namespace demfem::output::detail
