#include "core/robust_kernel.h"

#include <charconv>
#include <cstdio>

namespace graphslam::core {

StatusOr<RobustKernel> ParseRobustKernel(std::string_view text) {
  RobustKernel kernel;
  std::string_view name = text;
  const size_t colon = text.find(':');
  if (colon != std::string_view::npos) {
    name = text.substr(0, colon);
    const std::string number(text.substr(colon + 1));
    char* end = nullptr;
    kernel.scale = std::strtod(number.c_str(), &end);
    if (number.empty() || end != number.c_str() + number.size() || !(kernel.scale > 0.0) ||
        !std::isfinite(kernel.scale)) {
      return Status::InvalidArgument("robust kernel '" + std::string(text) +
                                     "': scale must be a positive number");
    }
  }
  if (name == "none") {
    kernel.type = RobustKernel::Type::kNone;
  } else if (name == "huber") {
    kernel.type = RobustKernel::Type::kHuber;
  } else if (name == "cauchy") {
    kernel.type = RobustKernel::Type::kCauchy;
  } else {
    return Status::InvalidArgument("unknown robust kernel '" + std::string(text) +
                                   "'; expected none, huber[:c] or cauchy[:c]");
  }
  return kernel;
}

std::string RobustKernelName(const RobustKernel& kernel) {
  char buffer[64];
  switch (kernel.type) {
    case RobustKernel::Type::kNone: return "none";
    case RobustKernel::Type::kHuber: std::snprintf(buffer, sizeof(buffer), "huber:%g", kernel.scale); break;
    case RobustKernel::Type::kCauchy: std::snprintf(buffer, sizeof(buffer), "cauchy:%g", kernel.scale); break;
  }
  return buffer;
}

}  // namespace graphslam::core
