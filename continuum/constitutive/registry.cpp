#include "registry.hpp"

#include <stdexcept>

namespace demfem::continuum::constitutive {

Material Material::by_name(const std::string& name, mc::Parameters p) {
  if (name == "elastic") {
    p.plastic = false;
    return from(p);
  }
  if (name == "mohr-coulomb") {
    p.plastic = true;
    return from(p);
  }
  throw std::invalid_argument("unknown constitutive model '" + name +
                              "' (valid: elastic, mohr-coulomb)");
}

} // namespace demfem::continuum::constitutive
