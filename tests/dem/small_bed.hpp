// A 300-disk bed in a 1.5 m box (r 0.02–0.035 m, K_n 1e6 N/m), deposited in ≈ 1 s of wall time:
// the packing tests' scene. `packing` goes into [soil.dem.packing], `rest` after the walls.
#pragma once

#include <string>

namespace demfem::test {

inline std::string small_bed(const std::string& name, const std::string& packing = "",
                             const std::string& rest = "") {
  return R"(
[scene]
name = ")" +
         name + R"("
duration = 0.1
seed = 7
[domain]
polygon = [[0, 0], [1.5, 0], [1.5, 1.5], [0, 1.5]]
[soil.dem]
count = 300
radius = { uniform = [0.02, 0.035] }
kn = 1.0e6
ks = 3.0e5
mu_static = 0.5
mu_dynamic = 0.2
[soil.dem.packing]
damping = 0.05
max_time = 10.0
)" + packing +
         R"(
[[wall]]
name = "base"
points = [[0, 0], [1.5, 0]]
[[wall]]
name = "left"
points = [[0, 1.5], [0, 0]]
[[wall]]
name = "right"
points = [[1.5, 0], [1.5, 1.5]]
)" + rest;
}

} // namespace demfem::test
