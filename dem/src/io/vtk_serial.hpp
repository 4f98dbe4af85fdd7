// Internal to dem/: VTK work on the calling thread only.
#pragma once

#include <functional>

namespace demfem::dem::io::detail {

// Runs `work` with vtkSMPTools on its sequential backend for that scope. VTK's writers compute
// every array's range through vtkSMPTools; with Debian's TBB backend that starts a worker thread
// which, after each parallel loop, spins in sched_yield for milliseconds: ≈ 2,000 yields a second
// through a wall run, taking the core that the other job or the other DEM thread needs. A
// snapshot's arrays are too small to gain from threads. (Compiled as C++17: VTK 9.1's
// vtkSMPTools.h declares constructors with template-ids, which C++20 refuses.)
void vtk_serially(const std::function<void()>& work);

} // namespace demfem::dem::io::detail
