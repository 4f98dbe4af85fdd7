#include "demfem/continuum/run.hpp"

namespace demfem::continuum {

RunSummary run(const scene::Scene& /*scene*/, const RunOptions& /*options*/) {
  RunSummary s;
  s.message = "the continuum solver is not built yet";
  return s;
}

} // namespace demfem::continuum
