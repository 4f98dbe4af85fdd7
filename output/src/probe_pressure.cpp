#include "demfem/output/contract.hpp"
#include "probe_kinds.hpp"

namespace demfem::output::detail {

PressureProbe::PressureProbe(std::string target, int bins, double interval)
    : Probe(file::pressure(target), interval), target_(std::move(target)), bins_(bins) {}

std::vector<std::string> PressureProbe::columns() const {
  std::vector<std::string> c{heading(col::time)};
  for (int b = 0; b < bins_; ++b) c.push_back(bin_heading(target_, b, col::pressure_bin));
  return c;
}

void PressureProbe::fill(ProbeSource& source, std::vector<double>& v) {
  const std::size_t at = v.size();
  v.resize(at + static_cast<std::size_t>(bins_), 0.0);
  source.pressure(target_, std::span<double>(v).subspan(at));
}

} // namespace demfem::output::detail
