#include "demfem/output/contract.hpp"
#include "probe_kinds.hpp"

namespace demfem::output::detail {

SurfaceProbe::SurfaceProbe(int bins, double interval)
    : Probe(std::string(file::surface), interval), bins_(bins) {}

std::vector<std::string> SurfaceProbe::columns() const {
  std::vector<std::string> c{heading(col::time)};
  for (int b = 0; b < bins_; ++b) c.push_back(bin_heading(col::surface_owner, b, col::surface_bin));
  return c;
}

void SurfaceProbe::fill(ProbeSource& source, std::vector<double>& v) {
  const std::size_t at = v.size();
  v.resize(at + static_cast<std::size_t>(bins_), 0.0);
  source.surface(std::span<double>(v).subspan(at));
}

} // namespace demfem::output::detail
