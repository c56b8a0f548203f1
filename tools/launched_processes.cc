#include <cstdlib>
#include <string>

#include "tools/distributed_solve_command.h"

namespace graphslam::tools {

int LaunchedProcesses() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"}) {
    if (const char* value = std::getenv(name); value != nullptr) {
      const int size = std::atoi(value);
      if (size > 0) return size;
    }
  }
  return 0;
}

}  // namespace graphslam::tools
