#include "partition/initialization/first_sight_initialization.h"

#include <algorithm>
#include <numeric>
#include <string_view>
#include <utility>

#include "core/initialization.h"

namespace graphslam::partition {

FirstSightInitialization::FirstSightInitialization(std::string scratch_path)
    : path_(std::move(scratch_path)) {}

FirstSightInitialization::~FirstSightInitialization() {
  file_.reset();
  // Scratch: a leftover is harmless (the ingest empties WORK).
  if (storage::Env::Default()->FileExists(path_))
    static_cast<void>(storage::Env::Default()->RemoveFile(path_));
}

int32_t FirstSightInitialization::Find(int32_t pose) {
  while (parent_[pose] != pose) {
    parent_[pose] = parent_[parent_[pose]];
    pose = parent_[pose];
  }
  return pose;
}

Status FirstSightInitialization::Flush() {
  if (buffer_.empty()) return Status::Ok();
  if (!file_) {
    GS_ASSIGN_OR_RETURN(file_, storage::Env::Default()->NewWritableFile(path_));
  }
  GS_RETURN_IF_ERROR(encoder_.Encode(buffer_.data(), buffer_.size(), &frame_));
  GS_RETURN_IF_ERROR(file_->Append(std::string_view(frame_.data(), frame_.size())));
  buffer_.clear();
  return Status::Ok();
}

Status FirstSightInitialization::Add(const core::Observation& observation,
                                     const FeatureIndex& index) {
  GS_CHECK(observation.feature >= 0 && observation.pose >= 0);
  if (observation.pose >= static_cast<int32_t>(parent_.size())) {
    const size_t old = parent_.size();
    parent_.resize(std::max<size_t>(observation.pose + 1, 2 * old));
    std::iota(parent_.begin() + static_cast<std::ptrdiff_t>(old), parent_.end(),
              static_cast<int32_t>(old));
  }
  const auto feature = static_cast<size_t>(observation.feature);
  if (feature >= index.counts().size() || index.counts()[feature] == 0) {
    if (buffer_.capacity() < kBlock) buffer_.reserve(kBlock);
    buffer_.push_back(observation);
    ++first_sights_;
    return buffer_.size() >= kBlock ? Flush() : Status::Ok();
  }
  // The lowest pose seen so far is in f's component (header).
  const int32_t a = Find(index.first_pose()[feature]), b = Find(observation.pose);
  if (a == b) return Status::Ok();  // adds no connectivity
  parent_[a] = b;
  joining_.push_back(observation);
  return Status::Ok();
}

template <typename Visit>
Status FirstSightInitialization::ReadBack(const Visit& visit) const {
  if (first_sights_ == 0) return Status::Ok();
  GS_ASSIGN_OR_RETURN(std::unique_ptr<storage::ReadableFile> file,
                      storage::Env::Default()->NewReadableFile(path_));
  SpillFrameDecoder decoder;
  std::vector<core::Observation> block;
  int64_t offset = 0, read = 0;
  while (true) {
    block.clear();
    GS_ASSIGN_OR_RETURN(const bool more, decoder.ReadFrame(path_, file.get(), &offset, &block));
    if (!more) break;
    for (const core::Observation& o : block) GS_RETURN_IF_ERROR(visit(o));
    read += static_cast<int64_t>(block.size());
  }
  if (read != first_sights_)
    return Status::Corruption(path_ + ": " + std::to_string(read) + " first sights in its frames; " +
                              std::to_string(first_sights_) + " were written to it");
  return Status::Ok();
}

Status FirstSightInitialization::Initialize(core::Problem2d* problem) {
  GS_CHECK(problem != nullptr && problem->observations.empty());
  GS_RETURN_IF_ERROR(Flush());
  if (file_) {
    GS_RETURN_IF_ERROR(file_->Close());
    file_.reset();
  }
  parent_ = std::vector<int32_t>();
  buffer_ = std::vector<core::Observation>();

  // 1. Check every first sight; keep those of the joining features.
  std::vector<int32_t> joined;
  joined.reserve(joining_.size());
  for (const core::Observation& o : joining_) joined.push_back(o.feature);
  std::sort(joined.begin(), joined.end());
  joined.erase(std::unique(joined.begin(), joined.end()), joined.end());
  std::vector<core::Observation> kept;
  GS_RETURN_IF_ERROR(ReadBack([&](const core::Observation& o) -> Status {
    GS_RETURN_IF_ERROR(core::CheckObservation(*problem, o));
    if (std::binary_search(joined.begin(), joined.end(), o.feature)) kept.push_back(o);
    return Status::Ok();
  }));
  GS_CHECK(kept.size() == joined.size());

  // 2. Validation, poses, connectivity, the joining features' placement, on
  // the problem with only the joined features (renumbered to their rank in
  // `joined`): the others have no observation here, so they join nothing,
  // and the union-find and flags of InitializeProblem stay O(poses).
  kept.insert(kept.end(), joining_.begin(), joining_.end());
  joining_ = std::vector<core::Observation>();
  for (core::Observation& o : kept) {
    o.feature = static_cast<int32_t>(std::lower_bound(joined.begin(), joined.end(), o.feature) -
                                     joined.begin());
  }
  std::vector<core::Point2> features = std::move(problem->features);
  std::vector<int64_t> feature_ids = std::move(problem->feature_ids);
  std::vector<uint8_t> feature_initialized = std::move(problem->feature_initialized);
  problem->features.clear();
  problem->feature_ids.clear();
  problem->feature_initialized.clear();
  for (const int32_t f : joined) {
    problem->features.push_back(features[static_cast<size_t>(f)]);
    problem->feature_ids.push_back(feature_ids[static_cast<size_t>(f)]);
    problem->feature_initialized.push_back(feature_initialized[static_cast<size_t>(f)]);
  }
  problem->observations = std::move(kept);
  const Status status = core::InitializeProblem(problem);
  problem->observations = std::vector<core::Observation>();
  for (size_t j = 0; j < joined.size(); ++j) {
    const auto f = static_cast<size_t>(joined[j]);
    features[f] = problem->features[j];
    feature_initialized[f] = problem->feature_initialized[j];
  }
  problem->features = std::move(features);
  problem->feature_ids = std::move(feature_ids);
  problem->feature_initialized = std::move(feature_initialized);
  GS_RETURN_IF_ERROR(status);

  // 3. Every other feature, by its first sight.
  GS_RETURN_IF_ERROR(ReadBack([&](const core::Observation& o) -> Status {
    core::PlaceFeature(problem, o);
    return Status::Ok();
  }));
  static_cast<void>(storage::Env::Default()->RemoveFile(path_));  // scratch, read back
  return Status::Ok();
}

}  // namespace graphslam::partition
