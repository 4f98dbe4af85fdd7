// libFuzzer target: the scene loader (TOML text → validated, resolved scenes). See scripts/fuzz.
#include "targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  demfem::fuzz::scene_input({data, size});
  return 0;
}
