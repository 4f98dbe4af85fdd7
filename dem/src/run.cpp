#include "demfem/dem/run.hpp"

#include <stdexcept>

namespace demfem::dem {

RunSummary run(const scene::Scene& /*scene*/, const RunOptions& /*options*/) {
  RunSummary s;
  s.ok = false;
  s.message = "the DEM engine is not built yet";
  return s;
}

} // namespace demfem::dem
