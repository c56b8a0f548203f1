#include "storage/solver_checkpoint.h"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "storage/atomic_file.h"

namespace graphslam::storage {
namespace {

Status Bad(const std::string& path, const std::string& what) {
  return Status::Corruption(path + ": " + what);
}

}  // namespace

Status WriteSolverCheckpoint(Env* env, const std::string& path, const std::string& input,
                             const core::SolverCheckpoint& checkpoint) {
  nlohmann::json json;
  json["format"] = kSolverCheckpointFormat;
  json["version"] = kSolverCheckpointVersion;
  json["input"] = input;
  json["iterations"] = checkpoint.iterations;
  json["trust_region_radius"] = checkpoint.trust_region_radius;
  json["decrease_factor"] = checkpoint.decrease_factor;
  json["initial_chi2"] = checkpoint.initial_chi2;
  json["chi2"] = checkpoint.chi2;
  json["converged"] = checkpoint.converged;
  json["termination"] = checkpoint.termination;
  std::vector<double> poses;
  poses.reserve(3 * checkpoint.poses.size());
  for (const core::Pose2& p : checkpoint.poses) poses.insert(poses.end(), {p.x(), p.y(), p.z()});
  std::vector<double> features;
  features.reserve(2 * checkpoint.features.size());
  for (const core::Point2& f : checkpoint.features) features.insert(features.end(), {f.x(), f.y()});
  json["poses"] = poses;
  json["features"] = features;
  json["excluded"] = checkpoint.excluded;
  json["kept"] = checkpoint.kept;
  // nlohmann writes doubles with max_digits10: they read back bit for bit.
  return WriteStringAtomically(env, path, json.dump() + "\n");
}

StatusOr<core::SolverCheckpoint> ReadSolverCheckpoint(const std::string& path,
                                                      const std::string& input) {
  std::ifstream in(path);
  if (!in) return Status::NotFound(path + ": cannot open checkpoint");
  nlohmann::json json = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded() || !json.is_object()) return Bad(path, "not a JSON object");
  if (json.value("format", "") != kSolverCheckpointFormat)
    return Bad(path, std::string("format is not '") + kSolverCheckpointFormat + "'");
  if (!json.contains("version") || !json["version"].is_number_integer())
    return Bad(path, "missing integer 'version'");
  const int version = json["version"].get<int>();
  if (version > kSolverCheckpointVersion)
    return Status::NotSupported(path + ": checkpoint version " + std::to_string(version) +
                                "; this build reads up to " +
                                std::to_string(kSolverCheckpointVersion));
  if (json.value("input", "") != input)
    return Status::InvalidArgument(path + ": checkpoint belongs to input '" +
                                   json.value("input", "") + "', expected '" + input + "'");
  core::SolverCheckpoint checkpoint;
  try {
    checkpoint.iterations = json.at("iterations").get<int>();
    checkpoint.trust_region_radius = json.at("trust_region_radius").get<double>();
    checkpoint.decrease_factor = json.at("decrease_factor").get<double>();
    checkpoint.initial_chi2 = json.at("initial_chi2").get<double>();
    checkpoint.chi2 = json.at("chi2").get<double>();
    checkpoint.converged = json.at("converged").get<bool>();
    checkpoint.termination = json.at("termination").get<std::string>();
    const auto poses = json.at("poses").get<std::vector<double>>();
    const auto features = json.at("features").get<std::vector<double>>();
    checkpoint.excluded = json.at("excluded").get<std::vector<uint8_t>>();
    checkpoint.kept = json.at("kept").get<std::vector<uint8_t>>();
    if (poses.size() % 3 != 0) return Bad(path, "'poses' length is not a multiple of 3");
    if (features.size() % 2 != 0) return Bad(path, "'features' length is not a multiple of 2");
    for (size_t i = 0; i < poses.size(); i += 3)
      checkpoint.poses.emplace_back(poses[i], poses[i + 1], poses[i + 2]);
    for (size_t i = 0; i < features.size(); i += 2)
      checkpoint.features.emplace_back(features[i], features[i + 1]);
  } catch (const nlohmann::json::exception& error) {
    return Bad(path, std::string("malformed field: ") + error.what());
  }
  if (checkpoint.iterations < 0) return Bad(path, "'iterations' is negative");
  if (!(checkpoint.trust_region_radius > 0) || !std::isfinite(checkpoint.trust_region_radius))
    return Bad(path, "'trust_region_radius' must be positive and finite");
  if (checkpoint.excluded.size() != checkpoint.features.size() ||
      checkpoint.kept.size() != checkpoint.features.size())
    return Bad(path, "'excluded' and 'kept' must have one entry per feature (" +
                         std::to_string(checkpoint.features.size()) + ")");
  for (const core::Pose2& p : checkpoint.poses)
    if (!p.allFinite()) return Bad(path, "a pose is not finite");
  for (const core::Point2& f : checkpoint.features)
    if (!f.allFinite()) return Bad(path, "a feature is not finite");
  return checkpoint;
}

}  // namespace graphslam::storage
