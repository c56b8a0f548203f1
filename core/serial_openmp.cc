#include "core/serial_openmp.h"

#include <dlfcn.h>
#include <omp.h>

namespace graphslam::core {

SerialOpenMpRegions::SerialOpenMpRegions() : saved_(omp_get_max_active_levels()) {
  omp_set_max_active_levels(0);
}

SerialOpenMpRegions::~SerialOpenMpRegions() { omp_set_max_active_levels(saved_); }

}  // namespace graphslam::core

namespace {

using ParallelEntry = void (*)(void (*)(void*), void*, unsigned, unsigned);

// libgomp's own GOMP_parallel (the version CHOLMOD binds to), or null when
// no OpenMP runtime is loaded.
ParallelEntry LibgompParallel() {
  static const ParallelEntry entry =
      reinterpret_cast<ParallelEntry>(dlvsym(RTLD_NEXT, "GOMP_parallel", "GOMP_4.0"));
  return entry;
}

}  // namespace

// The header's interposition of libgomp's entry point for
// `#pragma omp parallel` (GCC's ABI: the outlined body, its data, the
// num_threads clause or 0, flags).
extern "C" void GOMP_parallel(void (*fn)(void*), void* data, unsigned num_threads,
                              unsigned flags) {
  const ParallelEntry libgomp = LibgompParallel();
  if (libgomp == nullptr || omp_get_max_active_levels() == 0) {
    fn(data);
    return;
  }
  libgomp(fn, data, num_threads, flags);
}
