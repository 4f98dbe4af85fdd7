#include "demfem/output/contract.hpp"
#include "probe_kinds.hpp"

namespace demfem::output::detail {

WallsProbe::WallsProbe(std::vector<std::string> targets, double interval)
    : Probe(std::string(file::walls), interval), targets_(std::move(targets)) {}

std::vector<std::string> WallsProbe::columns() const {
  std::vector<std::string> c{heading(col::time)};
  for (const auto& w : targets_)
    for (const Column& q : kWallColumns) c.push_back(heading(w, q));
  return c;
}

void WallsProbe::fill(ProbeSource& source, std::vector<double>& v) {
  for (const auto& w : targets_) {
    const WallReaction r = source.wall(w);
    v.insert(v.end(), {r.thrust, r.reaction_x, r.reaction_z});
  }
}

} // namespace demfem::output::detail
