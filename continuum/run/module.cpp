// The continuum module's one exported symbol (module.hpp): the table of the solver's entry points.
#include "demfem/continuum/module.hpp"

extern "C" __attribute__((visibility("default"))) const demfem::continuum::ModuleApi*
demfem_continuum_module_api() {
  using namespace demfem::continuum;
  static const ModuleApi api = [] {
    ModuleApi a;
    a.run = &run;
    a.stable_step = &stable_step;
    a.flamant_strip_load = &flamant_strip_load;
    a.rocking_locking_case = &rocking_locking_case;
    a.stiff_structure_case = &stiff_structure_case;
    a.bearing_capacity_case = &bearing_capacity_case;
    a.scene_locking_case = &scene_locking_case;
    a.explicit_step_case = &explicit_step_case;
    return a;
  }();
  return &api;
}
