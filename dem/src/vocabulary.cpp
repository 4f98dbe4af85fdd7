#include "demfem/dem/vocabulary.hpp"

#include "demfem/dem/contact/registry.hpp"
#include "demfem/dem/stable_step.hpp"

namespace demfem::dem {

scene::Vocabulary vocabulary() {
  scene::Vocabulary v;
  v.dem = contact::slots();
  v.dem_step_limit = &scene_step_limit;
  return v;
}

} // namespace demfem::dem
