// Finds and loads libgraphslam_pcl (storage/internal/pcl_module_api.h) on
// first use.
//
// Looked for in the build tree's library folder, then in the installed
// PREFIX/LIBDIR/graphslam/ (both fixed at configure time). Loaded with
// dlopen(RTLD_NOW | RTLD_LOCAL) on every call and never closed: the dynamic
// loader keeps the one copy and returns it again, so this keeps no state of
// its own.
//
// THREAD SAFETY: any thread (dlopen and dlsym are thread-safe).
#pragma once

#include "core/status.h"
#include "storage/internal/pcl_module_api.h"

namespace graphslam::map::internal {

// The module's functions; NotSupported naming every place searched and the
// loader's errors when the module is missing, cannot load, or was built with
// another kPclModuleApiVersion.
StatusOr<const PclModuleApi*> LoadPclModule();

}  // namespace graphslam::map::internal
