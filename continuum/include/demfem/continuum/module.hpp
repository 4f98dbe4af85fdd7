// The continuum solver as the `demfem` program loads it: a shared module (libdemfem-continuum.so,
// target demfem_continuum_module) opened at the first continuum call, so that a DEM-only run never
// loads deal.II, PETSc, Trilinos or MPI (≈ 200 shared libraries, ≈ 0.5 s of start-up per
// process). The module exports one C function returning this table; the program checks `abi` and
// `size` before using it. Types cross the boundary as the headers declare them (both sides are
// built from this tree with the same compiler and standard library).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>

#include "demfem/continuum/run.hpp"
#include "demfem/continuum/stability.hpp"
#include "demfem/continuum/verification.hpp"

namespace demfem::continuum {

inline constexpr std::uint32_t kModuleAbi = 2; // bump when the table or a type in it changes
inline constexpr const char* kModuleEntry = "demfem_continuum_module_api";
inline constexpr const char* kModuleFile = "libdemfem-continuum.so";

struct ModuleApi {
  std::uint32_t abi = kModuleAbi;
  std::size_t size = sizeof(ModuleApi);
  RunSummary (*run)(const scene::Scene&, const RunOptions&) = nullptr;
  std::optional<scene::ContinuumStepLimit> (*stable_step)(const scene::Scene&,
                                                          const RunOptions&) = nullptr;
  FlamantResult (*flamant_strip_load)(int refinement, int degree) = nullptr;
  StabilityCase (*rocking_locking_case)(double nu, bool bbar, int degree) = nullptr;
  StabilityCase (*stiff_structure_case)(double ratio, int degree) = nullptr;
  StabilityCase (*bearing_capacity_case)(double factor, int degree) = nullptr;
  StabilityCase (*scene_locking_case)(const scene::Scene&, double nu, bool bbar) = nullptr;
  StabilityCase (*explicit_step_case)(const scene::Scene&, double factor) = nullptr;
};

} // namespace demfem::continuum
