// Compiled as C++17 (dem/CMakeLists.txt): see vtk_serial.hpp.
#include "vtk_serial.hpp"

#include <vtkSMPTools.h>

namespace demfem::dem::io::detail {

void vtk_serially(const std::function<void()>& work) {
  vtkSMPTools::LocalScope(vtkSMPTools::Config{1, "Sequential", false}, work);
}

} // namespace demfem::dem::io::detail
