// libFuzzer target: checkpoint loading (file → particles, meta, engine run state). See
// scripts/fuzz.
#include "targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  demfem::fuzz::checkpoint_input({data, size});
  return 0;
}
