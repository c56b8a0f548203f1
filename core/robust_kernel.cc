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

namespace {

Status ApplyOne(std::string_view text, RobustKernel* observation, PoseFactorKernels* pose_factors) {
  const size_t equals = text.find('=');
  const std::string_view type =
      equals == std::string_view::npos ? std::string_view("observation") : text.substr(0, equals);
  const std::string_view value = equals == std::string_view::npos ? text : text.substr(equals + 1);
  StatusOr<RobustKernel> kernel = ParseRobustKernel(value);
  if (!kernel.ok()) return kernel.status();
  if (type == "observation") {
    *observation = *kernel;
  } else if (type == "odometry") {
    pose_factors->relative_pose = *kernel;
    pose_factors->motion = *kernel;
  } else if (type == "motion") {
    pose_factors->motion = *kernel;
  } else if (type == "gps") {
    pose_factors->gps = *kernel;
  } else if (type == "robot") {
    pose_factors->robot = *kernel;
  } else {
    return Status::InvalidArgument("robust kernel '" + std::string(text) +
                                   "': unknown constraint type '" + std::string(type) +
                                   "'; expected observation, odometry, motion, gps or robot");
  }
  return Status::Ok();
}

}  // namespace

Status ApplyRobustKernelOption(std::string_view text, RobustKernel* observation,
                               PoseFactorKernels* pose_factors) {
  RobustKernel new_observation = *observation;
  PoseFactorKernels new_pose_factors = *pose_factors;
  size_t begin = 0;
  while (begin < text.size()) {
    size_t end = text.find_first_of(" ,\n\t", begin);
    if (end == std::string_view::npos) end = text.size();
    if (end > begin)
      GS_RETURN_IF_ERROR(ApplyOne(text.substr(begin, end - begin), &new_observation,
                                  &new_pose_factors));
    begin = end + 1;
  }
  *observation = new_observation;
  *pose_factors = new_pose_factors;
  return Status::Ok();
}

std::string RobustKernelsName(const RobustKernel& observation, const PoseFactorKernels& pose) {
  std::string out;
  auto add = [&](const char* type, const RobustKernel& kernel) {
    if (kernel.type == RobustKernel::Type::kNone) return;
    if (!out.empty()) out += ' ';
    out += type;
    out += '=';
    out += RobustKernelName(kernel);
  };
  add("observation", observation);
  if (pose.relative_pose.type == pose.motion.type && pose.relative_pose.scale == pose.motion.scale) {
    add("odometry", pose.relative_pose);
  } else {
    // "odometry=K" also sets the motion: name the motion explicitly after it.
    add("odometry", pose.relative_pose);
    if (!out.empty()) out += ' ';
    out += "motion=" + RobustKernelName(pose.motion);
  }
  add("gps", pose.gps);
  add("robot", pose.robot);
  return out.empty() ? "none" : out;
}

}  // namespace graphslam::core
