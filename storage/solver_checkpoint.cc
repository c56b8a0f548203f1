#include "storage/solver_checkpoint.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "storage/atomic_file.h"
#include "storage/chunk_format.h"
#include "storage/feature_record_file.h"
#include "storage/solver_state_file.h"
#include "storage/crc32c.h"
#include "storage/sealed_json_text.h"
#include "storage/stop_point.h"

namespace graphslam::storage {
namespace {

Status Bad(const std::string& path, const std::string& what) {
  return Status::Corruption(path + ": " + what);
}

// How a pose and a feature of each dimension are stored: a flat array of
// kValues numbers per element.
struct Planar {
  static constexpr int kDimension = 2;
  static constexpr int kPoseValues = 3;     // x, y, theta
  static constexpr int kFeatureValues = 2;  // x, y
  static void AppendPose(const core::Pose2& p, std::vector<double>* out) {
    out->insert(out->end(), {p.x(), p.y(), p.z()});
  }
  static core::Pose2 PoseAt(const double* v) { return core::Pose2(v[0], v[1], v[2]); }
  static bool Finite(const core::Pose2& p) { return p.allFinite(); }
};

struct Spatial {
  static constexpr int kDimension = 3;
  static constexpr int kPoseValues = 7;     // x, y, z, qx, qy, qz, qw (g2o order)
  static constexpr int kFeatureValues = 3;  // x, y, z
  static void AppendPose(const core::Pose3& p, std::vector<double>* out) {
    out->insert(out->end(),
                {p.t.x(), p.t.y(), p.t.z(), p.q.x(), p.q.y(), p.q.z(), p.q.w()});
  }
  static core::Pose3 PoseAt(const double* v) {
    core::Pose3 pose;
    pose.t = Eigen::Vector3d(v[0], v[1], v[2]);
    pose.q = Eigen::Quaterniond(v[6], v[3], v[4], v[5]);  // stored as written: no renormalization
    return pose;
  }
  static bool Finite(const core::Pose3& p) { return p.t.allFinite() && p.q.coeffs().allFinite(); }
};

nlohmann::json PcgStateToJson(const core::PcgSolverState& state) {
  nlohmann::json json;
  json["eta"] = state.eta;
  json["previous_rhs_norm"] = state.previous_rhs_norm;
  json["last_rhs_norm"] = state.last_rhs_norm;
  json["have_previous"] = state.have_previous;
  json["previous_x"] = state.previous_x;
  json["forest_order"] = state.forest_order;
  json["forest_parent"] = state.forest_parent;
  return json;
}

// Throws nlohmann::json::exception on a missing or mistyped field; the sizes
// and the forest are checked against the problem by the solver.
core::PcgSolverState PcgStateFromJson(const nlohmann::json& json) {
  core::PcgSolverState state;
  state.present = true;
  state.eta = json.at("eta").get<double>();
  state.previous_rhs_norm = json.at("previous_rhs_norm").get<double>();
  state.last_rhs_norm = json.at("last_rhs_norm").get<double>();
  state.have_previous = json.at("have_previous").get<bool>();
  state.previous_x = json.at("previous_x").get<std::vector<double>>();
  state.forest_order = json.at("forest_order").get<std::vector<int>>();
  state.forest_parent = json.at("forest_parent").get<std::vector<int>>();
  return state;
}

// Everything but the per-feature arrays; with `poses_and_pcg` false also
// without the poses and the PCG state (version 4: they are in the state file).
template <class Layout, class Checkpoint>
nlohmann::json HeadJson(const std::string& input, const Checkpoint& checkpoint,
                        bool poses_and_pcg = true) {
  nlohmann::json json;
  json["format"] = kSolverCheckpointFormat;
  // Version 2 only with the "pcg" object: a CHOLMOD checkpoint stays readable
  // by version-1 builds, while a version-1 build, which would resume a PCG
  // solve without its state (not bit-identical), refuses a PCG checkpoint.
  json["version"] = checkpoint.pcg.present ? 2 : 1;  // 3, 4: only with a feature file
  json["input"] = input;
  // Only 3-D checkpoints carry the key: 2-D files stay as version 1 wrote them.
  if (Layout::kDimension != 2) json["dimension"] = Layout::kDimension;
  json["iterations"] = checkpoint.iterations;
  json["trust_region_radius"] = checkpoint.trust_region_radius;
  json["decrease_factor"] = checkpoint.decrease_factor;
  json["initial_chi2"] = checkpoint.initial_chi2;
  json["chi2"] = checkpoint.chi2;
  json["converged"] = checkpoint.converged;
  json["termination"] = checkpoint.termination;
  if (!poses_and_pcg) return json;
  std::vector<double> poses;
  poses.reserve(Layout::kPoseValues * checkpoint.poses.size());
  for (const auto& p : checkpoint.poses) Layout::AppendPose(p, &poses);
  json["poses"] = poses;
  if (checkpoint.pcg.present) json["pcg"] = PcgStateToJson(checkpoint.pcg);
  return json;
}

template <class Layout, class Checkpoint>
Status Write(Env* env, const std::string& path, const std::string& input,
             const Checkpoint& checkpoint) {
  // nlohmann writes doubles with max_digits10: they read back bit for bit.
  std::string head = HeadJson<Layout>(input, checkpoint).dump();
  head.pop_back();  // the closing '}': the per-feature arrays follow
  // The per-feature arrays (2-3 numbers and two flags per feature: 10^7 and
  // more) are formatted straight into the file in ~1 MiB appends instead of
  // through a JSON tree and its dump string (~190 bytes per feature at the
  // peak). std::to_chars gives the shortest text that reads back to the same
  // double, as nlohmann's dump does, so the document reads as before.
  return WriteFileAtomically(env, path, [&](WritableFile* file) -> Status {
    std::string text = std::move(head);
    uint32_t crc = 0;  // of every byte appended: the seal covers them
    const auto spill = [&](bool force) -> Status {
      if (!force && text.size() < (size_t{1} << 20)) return Status::Ok();
      crc = crc32c::Extend(crc, text.data(), text.size());
      Status status = file->Append(text);
      text.clear();
      return status;
    };
    char number[32];
    const auto append_flags = [&](const char* key, const std::vector<uint8_t>& flags) -> Status {
      text += ",\"";
      text += key;
      text += "\":[";
      for (size_t i = 0; i < flags.size(); ++i) {
        if (i > 0) text.push_back(',');
        text.push_back(flags[i] != 0 ? '1' : '0');
        GS_RETURN_IF_ERROR(spill(false));
      }
      text.push_back(']');
      return Status::Ok();
    };
    GS_RETURN_IF_ERROR(append_flags("excluded", checkpoint.excluded));
    text += ",\"features\":[";
    bool first = true;
    for (const auto& f : checkpoint.features) {
      for (int k = 0; k < Layout::kFeatureValues; ++k) {
        if (!first) text.push_back(',');
        first = false;
        const double value = f[k];
        if (!std::isfinite(value)) {  // as nlohmann (the reader rejects it)
          text += "null";
          continue;
        }
        char* const end = std::to_chars(number, number + sizeof(number), value).ptr;
        text.append(number, end);
        // As nlohmann: an integral double is written "1.0", not "1".
        if (std::find_if(number, end, [](char c) { return c == '.' || c == 'e'; }) == end)
          text += ".0";
      }
      GS_RETURN_IF_ERROR(spill(false));
    }
    text.push_back(']');
    GS_RETURN_IF_ERROR(append_flags("kept", checkpoint.kept));
    GS_RETURN_IF_ERROR(spill(true));
    return file->Append(JsonSealFor(crc));
  });
}

constexpr uint32_t kFeaturesPerRecord = 65536;

std::string FeatureFileName(const std::string& path, int iterations) {
  return path + ".features." + std::to_string(iterations) + ".bin";
}

std::string StateFileName(const std::string& path, int iterations) {
  return path + ".state." + std::to_string(iterations) + ".bin";
}

// A file named by the checkpoint's JSON key `key`: a plain name beside it.
StatusOr<std::string> FileBeside(const std::string& path, const nlohmann::json& json,
                                 const char* key) {
  const std::string name = json.at(key).get<std::string>();
  if (name.empty() || name.find('/') != std::string::npos)
    return Bad(path, std::string("'") + key + "' must be a file name beside the checkpoint");
  return (std::filesystem::path(path).parent_path() / name).string();
}

// The feature file of a 2-D checkpoint (storage/feature_record_file.h, kind 2).
Status WriteFeatureFile(Env* env, const std::string& file_path,
                        const core::SolverCheckpoint& checkpoint) {
  using chunk_format::PutDouble;
  using chunk_format::PutFixed32;
  using chunk_format::PutFixed64;
  const size_t n = checkpoint.features.size();
  if (checkpoint.excluded.size() != n || checkpoint.kept.size() != n)
    return Status::InvalidArgument(file_path + ": 'excluded' and 'kept' need one entry per feature");
  return WriteFileAtomically(env, file_path, [&](WritableFile* file) -> Status {
    std::string out = feature_records::EncodeHeader(feature_records::kKindCheckpoint, 2);
    std::string payload;
    uint64_t records = 0;
    for (size_t first = 0; first < n; first += kFeaturesPerRecord) {
      const size_t count = std::min<size_t>(kFeaturesPerRecord, n - first);
      payload.clear();
      PutFixed64(&payload, first);
      PutFixed32(&payload, static_cast<uint32_t>(count));
      for (size_t g = first; g < first + count; ++g) {
        PutDouble(&payload, checkpoint.features[g].x());
        PutDouble(&payload, checkpoint.features[g].y());
      }
      for (size_t g = first; g < first + count; ++g)
        payload.push_back(static_cast<char>(checkpoint.excluded[g] != 0));
      for (size_t g = first; g < first + count; ++g)
        payload.push_back(static_cast<char>(checkpoint.kept[g] != 0));
      feature_records::AppendRecord(feature_records::kData, payload, &out);
      ++records;
      if (out.size() >= (size_t{1} << 20)) {
        GS_RETURN_IF_ERROR(file->Append(out));
        out.clear();
      }
    }
    out += feature_records::EncodeFooter(records, n);
    return file->Append(out);
  });
}

Status ReadFeatureFile(const std::string& file_path, int64_t expected,
                       core::SolverCheckpoint* checkpoint) {
  using chunk_format::DecodeDouble;
  using chunk_format::DecodeFixed32;
  using chunk_format::DecodeFixed64;
  GS_ASSIGN_OR_RETURN(std::unique_ptr<feature_records::Reader> reader,
                      feature_records::Reader::Open(file_path,
                                                    feature_records::kKindCheckpoint, 2));
  checkpoint->features.clear();
  checkpoint->excluded.clear();
  checkpoint->kept.clear();
  checkpoint->features.reserve(static_cast<size_t>(std::max<int64_t>(expected, 0)));
  checkpoint->excluded.reserve(checkpoint->features.capacity());
  checkpoint->kept.reserve(checkpoint->features.capacity());
  std::string payload;
  while (true) {
    GS_ASSIGN_OR_RETURN(bool more, reader->Next(&payload, checkpoint->features.size()));
    if (!more) break;
    const int64_t offset = reader->record_offset();
    if (payload.size() < 12) return reader->Bad(offset, "feature record shorter than 12 bytes");
    const uint64_t first = DecodeFixed64(payload.data());
    const uint64_t count = DecodeFixed32(payload.data() + 8);
    if (first != checkpoint->features.size())
      return reader->Bad(offset, "record starts at feature " + std::to_string(first) +
                                     ", expected " + std::to_string(checkpoint->features.size()));
    if (payload.size() != 12 + 18 * count)
      return reader->Bad(offset, "record of " + std::to_string(count) + " features has " +
                                     std::to_string(payload.size()) + " bytes, expected " +
                                     std::to_string(12 + 18 * count));
    const char* values = payload.data() + 12;
    const char* excluded = values + 16 * count;
    const char* kept = excluded + count;
    for (uint64_t k = 0; k < count; ++k) {
      checkpoint->features.emplace_back(DecodeDouble(values + 16 * k),
                                        DecodeDouble(values + 16 * k + 8));
      checkpoint->excluded.push_back(static_cast<uint8_t>(excluded[k]));
      checkpoint->kept.push_back(static_cast<uint8_t>(kept[k]));
    }
  }
  if (static_cast<int64_t>(checkpoint->features.size()) != expected)
    return Status::Corruption(file_path + ": " + std::to_string(checkpoint->features.size()) +
                              " features, the checkpoint names " + std::to_string(expected));
  return Status::Ok();
}

// The checkpoint's JSON object: sealed (storage/checksummed_json.h) and parsed.
StatusOr<nlohmann::json> ReadCheckpointJson(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::NotFound(path + ": cannot open checkpoint");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  GS_RETURN_IF_ERROR(CheckJsonTextSeal(path, text));
  nlohmann::json json = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded() || !json.is_object()) return Bad(path, "not a JSON object");
  return json;
}

// The format, a version this build reads, the input it was made on and the
// dimension of the solve.
template <class Layout>
Status CheckCheckpointHeader(const std::string& path, const nlohmann::json& json,
                             const std::string& input) {
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
  const nlohmann::json dimension = json.value("dimension", nlohmann::json(2));
  if (!dimension.is_number_integer() || dimension.get<int>() != Layout::kDimension)
    return Status::InvalidArgument(path + ": checkpoint of a " + dimension.dump() +
                                   "-D solve, expected " + std::to_string(Layout::kDimension) +
                                   "-D");
  return Status::Ok();
}

// The control state, poses, features and the PCG state, from the JSON or the
// files beside it (a 2-D feature file, version 3; a state file, version 4).
template <class Layout, class Checkpoint>
Status ReadCheckpointFields(const std::string& path, const nlohmann::json& json,
                            Checkpoint* checkpoint_out) {
  Checkpoint& checkpoint = *checkpoint_out;
  try {
    checkpoint.iterations = json.at("iterations").get<int>();
    checkpoint.trust_region_radius = json.at("trust_region_radius").get<double>();
    checkpoint.decrease_factor = json.at("decrease_factor").get<double>();
    checkpoint.initial_chi2 = json.at("initial_chi2").get<double>();
    checkpoint.chi2 = json.at("chi2").get<double>();
    checkpoint.converged = json.at("converged").get<bool>();
    checkpoint.termination = json.at("termination").get<std::string>();
    // Version 4: the poses and the PCG state are in a state file (below).
    const bool state_file = json.contains("state_file");
    const auto poses =
        state_file ? std::vector<double>() : json.at("poses").get<std::vector<double>>();
    // Version 3 with a feature file: the arrays are read from it below.
    const bool feature_file = json.contains("features_file");
    const auto features =
        feature_file ? std::vector<double>() : json.at("features").get<std::vector<double>>();
    if (!feature_file) {
      checkpoint.excluded = json.at("excluded").get<std::vector<uint8_t>>();
      checkpoint.kept = json.at("kept").get<std::vector<uint8_t>>();
    }
    // Absent in version 1 and in CHOLMOD checkpoints: a fresh PCG state.
    if (json.contains("pcg")) checkpoint.pcg = PcgStateFromJson(json.at("pcg"));
    if (poses.size() % Layout::kPoseValues != 0)
      return Bad(path, "'poses' length is not a multiple of " +
                           std::to_string(Layout::kPoseValues));
    if (features.size() % Layout::kFeatureValues != 0)
      return Bad(path, "'features' length is not a multiple of " +
                           std::to_string(Layout::kFeatureValues));
    for (size_t i = 0; i < poses.size(); i += Layout::kPoseValues)
      checkpoint.poses.push_back(Layout::PoseAt(&poses[i]));
    for (size_t i = 0; i < features.size(); i += Layout::kFeatureValues) {
      typename decltype(checkpoint.features)::value_type f;
      for (int k = 0; k < Layout::kFeatureValues; ++k) f[k] = features[i + k];
      checkpoint.features.push_back(f);
    }
    if (feature_file || state_file) {
      if constexpr (Layout::kDimension == 2) {
        if (feature_file) {
          GS_ASSIGN_OR_RETURN(const std::string file_path,
                              FileBeside(path, json, "features_file"));
          GS_RETURN_IF_ERROR(ReadFeatureFile(file_path, json.at("features_count").get<int64_t>(),
                                             &checkpoint));
        }
        if (state_file) {
          if (json.contains("poses") || json.contains("pcg"))
            return Bad(path, "'poses' or 'pcg' beside 'state_file'");
          GS_ASSIGN_OR_RETURN(const std::string file_path, FileBeside(path, json, "state_file"));
          GS_RETURN_IF_ERROR(ReadSolverStateFile(file_path, &checkpoint.poses, &checkpoint.pcg));
        }
      } else {
        return Bad(path, "'features_file' or 'state_file' in a 3-D checkpoint");
      }
    }
  } catch (const nlohmann::json::exception& error) {
    return Bad(path, std::string("malformed field: ") + error.what());
  }
  return Status::Ok();
}

// What a resumed solve relies on: sizes that agree, finite values.
template <class Layout, class Checkpoint>
Status CheckCheckpointValues(const std::string& path, const Checkpoint& checkpoint) {
  if (checkpoint.iterations < 0) return Bad(path, "'iterations' is negative");
  if (!(checkpoint.trust_region_radius > 0) || !std::isfinite(checkpoint.trust_region_radius))
    return Bad(path, "'trust_region_radius' must be positive and finite");
  if (checkpoint.excluded.size() != checkpoint.features.size() ||
      checkpoint.kept.size() != checkpoint.features.size())
    return Bad(path, "'excluded' and 'kept' must have one entry per feature (" +
                         std::to_string(checkpoint.features.size()) + ")");
  for (const auto& p : checkpoint.poses)
    if (!Layout::Finite(p)) return Bad(path, "a pose is not finite");
  for (const auto& f : checkpoint.features)
    if (!f.allFinite()) return Bad(path, "a feature is not finite");
  const core::PcgSolverState& pcg = checkpoint.pcg;
  if (pcg.present) {
    if (!std::isfinite(pcg.eta) || !(pcg.eta > 0) || !std::isfinite(pcg.previous_rhs_norm) ||
        !std::isfinite(pcg.last_rhs_norm))
      return Bad(path, "'pcg': eta must be positive and finite, the norms finite");
    for (double v : pcg.previous_x)
      if (!std::isfinite(v)) return Bad(path, "'pcg.previous_x' is not finite");
    if (pcg.forest_order.size() != pcg.forest_parent.size())
      return Bad(path, "'pcg.forest_order' has " + std::to_string(pcg.forest_order.size()) +
                           " entries, 'pcg.forest_parent' " +
                           std::to_string(pcg.forest_parent.size()));
  }
  return Status::Ok();
}

template <class Layout, class Checkpoint>
StatusOr<Checkpoint> Read(const std::string& path, const std::string& input) {
  GS_ASSIGN_OR_RETURN(const nlohmann::json json, ReadCheckpointJson(path));
  GS_RETURN_IF_ERROR(CheckCheckpointHeader<Layout>(path, json, input));
  Checkpoint checkpoint;
  GS_RETURN_IF_ERROR((ReadCheckpointFields<Layout, Checkpoint>(path, json, &checkpoint)));
  GS_RETURN_IF_ERROR((CheckCheckpointValues<Layout, Checkpoint>(path, checkpoint)));
  return checkpoint;
}

}  // namespace

Status WriteSolverCheckpoint(Env* env, const std::string& path, const std::string& input,
                             const core::SolverCheckpoint& checkpoint) {
  GS_RETURN_IF_ERROR(Write<Planar>(env, path, input, checkpoint));
  StopPointForTests("solver_checkpoint " + std::to_string(checkpoint.iterations));
  return Status::Ok();
}

Status WriteSolverCheckpoint(Env* env, const std::string& path, const std::string& input,
                             const core::SolverCheckpoint3d& checkpoint) {
  GS_RETURN_IF_ERROR(Write<Spatial>(env, path, input, checkpoint));
  StopPointForTests("solver_checkpoint " + std::to_string(checkpoint.iterations));
  return Status::Ok();
}

Status WriteSolverCheckpointWithFeatureFile(Env* env, const std::string& path,
                                            const std::string& input,
                                            const core::SolverCheckpoint& checkpoint) {
  // 1. the generation's feature and state files, durable before any JSON
  //    names them
  const std::string file_path = FeatureFileName(path, checkpoint.iterations);
  GS_RETURN_IF_ERROR(WriteFeatureFile(env, file_path, checkpoint));
  const std::string state_path = StateFileName(path, checkpoint.iterations);
  GS_RETURN_IF_ERROR(WriteSolverStateFile(env, state_path, checkpoint.poses, checkpoint.pcg));
  // 2. the JSON naming them (atomic: the previous JSON stays valid until
  //    here); a few hundred bytes, no array
  nlohmann::json json = HeadJson<Planar>(input, checkpoint, /*poses_and_pcg=*/false);
  json["version"] = kSolverCheckpointVersion;
  json["features_file"] = std::filesystem::path(file_path).filename().string();
  json["features_count"] = checkpoint.features.size();
  json["state_file"] = std::filesystem::path(state_path).filename().string();
  GS_RETURN_IF_ERROR(WriteStringAtomically(env, path, SealJsonText(json.dump())));
  // 3. other generations are garbage now (a kill before this leaves them:
  //    the next checkpoint removes them)
  const std::filesystem::path directory =
      std::filesystem::path(path).parent_path().empty() ? std::filesystem::path(".")
                                                        : std::filesystem::path(path).parent_path();
  const std::string base = std::filesystem::path(path).filename().string();
  const std::string keep[] = {std::filesystem::path(file_path).filename().string(),
                              std::filesystem::path(state_path).filename().string()};
  std::vector<std::string> garbage;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(directory, error)) {
    const std::string name = entry.path().filename().string();
    if (name == keep[0] || name == keep[1] || name.size() <= 4 ||
        name.compare(name.size() - 4, 4, ".bin") != 0)
      continue;
    for (const char* kind : {".features.", ".state."})
      if (name.rfind(base + kind, 0) == 0) garbage.push_back(entry.path().string());
  }
  for (const std::string& name : garbage) GS_RETURN_IF_ERROR(env->RemoveFile(name));
  StopPointForTests("solver_checkpoint " + std::to_string(checkpoint.iterations));
  return Status::Ok();
}

StatusOr<core::SolverCheckpoint> ReadSolverCheckpoint(const std::string& path,
                                                      const std::string& input) {
  return Read<Planar, core::SolverCheckpoint>(path, input);
}

StatusOr<core::SolverCheckpoint3d> ReadSolverCheckpoint3d(const std::string& path,
                                                          const std::string& input) {
  return Read<Spatial, core::SolverCheckpoint3d>(path, input);
}

}  // namespace graphslam::storage
