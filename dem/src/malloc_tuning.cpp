#include "demfem/dem/malloc_tuning.hpp"

#include <cstdlib> // <features.h>: __GLIBC__

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace demfem::dem {

void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 64 * 1024 * 1024);
#endif
}

} // namespace demfem::dem
