// The continuum solver's module (continuum/module.hpp), opened at the first call: a DEM-only run
// never loads deal.II and its libraries.
#pragma once

#include "demfem/continuum/module.hpp"

namespace demfem::app {

// The module's table. The first call opens the module: $DEMFEM_CONTINUUM_MODULE when set, else
// libdemfem-continuum.so beside this program, else where the build wrote it. Throws
// std::runtime_error naming every path tried and why it failed.
const continuum::ModuleApi& continuum_module();

} // namespace demfem::app
