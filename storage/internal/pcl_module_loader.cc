#include "storage/internal/pcl_module_loader.h"

#include <dlfcn.h>

#include <string>

namespace graphslam::map::internal {

StatusOr<const PclModuleApi*> LoadPclModule() {
  std::string tried;
  for (const char* path : {GRAPHSLAM_PCL_MODULE_BUILD_PATH, GRAPHSLAM_PCL_MODULE_INSTALL_PATH}) {
    void* handle = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* error = dlerror();
      tried += std::string("; ") + (error != nullptr ? error : path);
      continue;
    }
    using Entry = const PclModuleApi* (*)();
    const auto entry = reinterpret_cast<Entry>(dlsym(handle, kPclModuleEntry));
    if (entry == nullptr) {
      tried += std::string("; ") + path + ": no symbol " + kPclModuleEntry;
      continue;
    }
    const PclModuleApi* api = entry();
    if (api->version != kPclModuleApiVersion) {
      tried += std::string("; ") + path + ": interface version " + std::to_string(api->version) +
               ", expected " + std::to_string(kPclModuleApiVersion);
      continue;
    }
    return api;
  }
  return Status::NotSupported("PCD files need libgraphslam_pcl (PCL), which did not load" +
                              tried);
}

}  // namespace graphslam::map::internal
