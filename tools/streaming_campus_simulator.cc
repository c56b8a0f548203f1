#include "tools/streaming_campus_simulator.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/angle.h"
#include "core/velocity_motion_model.h"
#include "storage/atomic_file.h"
#include "storage/compressed_file.h"
#include "storage/native_log_counts.h"
#include "storage/env.h"
#include "storage/internal/text_reader.h"
#include "tools/internal/campus_world.h"

namespace graphslam::tools {
namespace {

using internal::DirectionAngle;
using internal::DirectionVector;
using internal::Grid;
using internal::kStepX;
using internal::kStepY;
using internal::Random;
using internal::StreetPath;
using storage::internal::AppendField;
using storage::internal::AppendUpperTriangle;

// SplitMix64 (Steele, Lea, Flood 2014): decorrelates the per-segment and
// per-run seeds derived from one user seed.
uint64_t SplitMix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

struct Landmark {
  int64_t slot = 0;  // id - feature_id_base
  core::Point2 position = core::Point2::Zero();
};

// The landmarks of the campus, generated per street segment on demand.
class ProceduralWorld {
 public:
  ProceduralWorld(const CampusSimulatorOptions& options, const Grid& grid, double keep)
      : options_(options), grid_(grid), keep_(keep) {
    const double usable = options.block_size - options.street_width;
    per_side_ = static_cast<int64_t>(std::floor(usable / options.min_landmark_spacing)) + 2;
  }

  int64_t NumSegmentSlots() const { return 2 * static_cast<int64_t>(grid_.columns) * grid_.rows; }
  int64_t NumSlots() const { return NumSegmentSlots() * 2 * per_side_; }

  // Landmarks of segment `s`, as PlaceLandmarks would place that one segment,
  // each kept with probability keep_ (the draw is made either way).
  void Generate(int64_t s, std::vector<Landmark>* out) const {
    out->clear();
    const int64_t node = s / 2;
    const int direction = static_cast<int>(s % 2);
    const int x = static_cast<int>(node % grid_.columns);
    const int y = static_cast<int>(node / grid_.columns);
    if (!grid_.Contains(x + kStepX[direction], y + kStepY[direction])) return;
    Random random(SplitMix64(SplitMix64(options_.seed) ^ SplitMix64(static_cast<uint64_t>(s) + 1)));
    const double half_width = 0.5 * options_.street_width;
    const double end = options_.block_size - half_width;
    const core::Point2 along = DirectionVector(direction);
    const core::Point2 normal = DirectionVector(direction + 1);
    for (int side = 0; side < 2; ++side) {
      const core::Point2 offset = (side == 0 ? half_width : -half_width) * normal;
      double t = half_width + random.Uniform(0.0, 0.5 * options_.min_landmark_spacing);
      for (int64_t slot = 0; t <= end; ++slot) {
        GS_CHECK(slot < per_side_);
        const bool keep = random.Uniform() < keep_;
        if (keep) {
          out->push_back({(s * 2 + side) * per_side_ + slot,
                          grid_.Node(x, y) + t * along + offset});
        }
        t += random.Uniform(options_.min_landmark_spacing, options_.max_landmark_spacing);
      }
    }
  }

  // Landmarks within `radius` of `center`, by slot.
  void Near(const core::Point2& center, double radius, std::vector<Landmark>* out) {
    out->clear();
    const double reach = radius + 0.5 * options_.street_width;
    const double b = grid_.block_size;
    const int x0 = std::max(0, static_cast<int>(std::floor((center.x() - reach) / b)) - 1);
    const int x1 = std::min(grid_.columns - 1, static_cast<int>(std::ceil((center.x() + reach) / b)));
    const int y0 = std::max(0, static_cast<int>(std::floor((center.y() - reach) / b)) - 1);
    const int y1 = std::min(grid_.rows - 1, static_cast<int>(std::ceil((center.y() + reach) / b)));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        for (int d = 0; d < 2; ++d) {
          const int64_t s = 2 * (static_cast<int64_t>(y) * grid_.columns + x) + d;
          for (const Landmark& landmark : Cached(s))
            if ((landmark.position - center).squaredNorm() <= radius * radius)
              out->push_back(landmark);
        }
      }
    }
    std::sort(out->begin(), out->end(),
              [](const Landmark& a, const Landmark& b) { return a.slot < b.slot; });
  }

 private:
  const std::vector<Landmark>& Cached(int64_t s) {
    auto it = cache_.find(s);
    if (it != cache_.end()) return it->second;
    // The robot moves locally: a bounded cache, dropped whole when full.
    if (cache_.size() >= 4096) cache_.clear();
    std::vector<Landmark>& landmarks = cache_[s];
    Generate(s, &landmarks);
    return landmarks;
  }

  const CampusSimulatorOptions& options_;
  const Grid& grid_;
  const double keep_;
  int64_t per_side_ = 0;
  std::unordered_map<int64_t, std::vector<Landmark>> cache_;
};

// Grid and keep probability, sized as BuildCampus sizes them.
double SizeCampus(const CampusSimulatorOptions& options, Grid* grid) {
  grid->columns = 3;
  grid->rows = 3;
  grid->block_size = options.block_size;
  if (options.features == 0) {
    const double distance = static_cast<double>(options.poses) * options.speed * options.dt;
    while (static_cast<double>(grid->Segments()) * options.block_size < 0.25 * distance)
      internal::Grow(grid);
    return 1.0;
  }
  const double per_segment = internal::ExpectedLandmarksPerSegment(options);
  while (static_cast<double>(grid->Segments()) * per_segment <
         1.05 * static_cast<double>(options.features))
    internal::Grow(grid);
  return std::min(1.0, static_cast<double>(options.features) /
                           (static_cast<double>(grid->Segments()) * per_segment));
}

// A file written through `env` to its temporary name, renamed into place by Commit().
class StreamedFile {
 public:
  StreamedFile(storage::Env* env, std::string path) : env_(env), path_(std::move(path)) {}
  Status Open() {
    GS_ASSIGN_OR_RETURN(file_, env_->NewWritableFile(storage::TemporaryFileName(path_)));
    return Status::Ok();
  }
  Status Append(std::string_view data) { return file_->Append(data); }
  Status Commit() {
    GS_RETURN_IF_ERROR(file_->Sync());
    GS_RETURN_IF_ERROR(file_->Close());
    GS_RETURN_IF_ERROR(env_->Rename(storage::TemporaryFileName(path_), path_));
    return env_->SyncDirectory(std::filesystem::path(path_).parent_path().string());
  }
  ~StreamedFile() {
    // An unfinished temporary goes; a failure to remove it is not reported
    // (the error that stopped the write is).
    if (file_ != nullptr) (void)env_->RemoveFile(storage::TemporaryFileName(path_));
  }

 private:
  storage::Env* env_;
  std::string path_;
  std::unique_ptr<storage::WritableFile> file_;
};

// The native log's lines, gathered into ~1 MiB appends to the file (through
// zstd, on one worker thread, when a level is given).
class LogLines {
 public:
  LogLines(storage::WritableFile* file, int zstd_level) : file_(file) {
    if (zstd_level > 0) zstd_.emplace(file, zstd_level, 1);
  }
  // The line being built; EndLine() ends it.
  std::string* line() { return &line_; }
  Status EndLine() {
    line_.push_back('\n');
    pending_ += line_;
    line_.clear();
    return pending_.size() >= (size_t{1} << 20) ? WritePending() : Status::Ok();
  }
  // Ends the log with `trailer` (storage/native_log_counts.h): in a zstd log
  // a frame of its own, so that it is read without decompressing the rest.
  Status Finish(std::string_view trailer) {
    if (!zstd_) {
      pending_ += trailer;
      return WritePending();
    }
    GS_RETURN_IF_ERROR(WritePending());
    GS_RETURN_IF_ERROR(zstd_->Finish());
    storage::ZstdWriter last(file_, kTrailerZstdLevel);
    GS_RETURN_IF_ERROR(last.Append(trailer));
    return last.Finish();
  }

 private:
  Status WritePending() {
    Status status = zstd_ ? zstd_->Append(pending_) : file_->Append(pending_);
    pending_.clear();
    return status;
  }

  static constexpr int kTrailerZstdLevel = 3;
  storage::WritableFile* file_;
  std::optional<storage::ZstdWriter> zstd_;
  std::string line_;
  std::string pending_;
};

// The streamed simulation: runs of the robot through the procedural world,
// each pose's records written to the log as they are drawn, the ground truth
// to the TUM file, the observation counts kept per landmark slot.
class StreamingSimulation {
 public:
  StreamingSimulation(const CampusSimulatorOptions& options, const Grid& grid,
                      ProceduralWorld* world, std::vector<uint16_t>* counts, StreamedFile* tum,
                      StreamingCampusSummary* summary)
      : options_(options), grid_(grid), world_(*world), counts_(*counts), tum_(*tum),
        summary_(*summary), half_fov_(0.5 * options.field_of_view),
        observation_information_(
            Eigen::Vector2d(1.0 / (options.range_sigma * options.range_sigma),
                            1.0 / (options.bearing_sigma * options.bearing_sigma))
                .asDiagonal()),
        gps_information_(Eigen::Matrix2d::Identity() / (options.gps_sigma * options.gps_sigma)),
        min_range_(5.0 * options.range_sigma) {}

  Status Write(LogLines* log) {
    *log->line() = "GRAPHSLAM_LOG 1";
    GS_RETURN_IF_ERROR(log->EndLine());
    *log->line() = "# graphslam simulate --streaming, seed " + std::to_string(options_.seed) +
                   " (spec: docs/formats/native_log.md)";
    GS_RETURN_IF_ERROR(log->EndLine());
    int64_t index = 0;
    for (int run = 0; run < options_.runs; ++run) GS_RETURN_IF_ERROR(Run(run, log, &index));
    summary_.poses = index;
    // The id range only when every id is >= 0 (a negative id base).
    return log->Finish(storage::NativeLogCountsLine(
        {summary_.poses, summary_.observed_features, summary_.observations,
         options_.feature_id_base >= 0 ? summary_.feature_id_end : -1}));
  }

 private:
  // One run from a random street corner; *index counts the poses of all runs.
  Status Run(int run, LogLines* log, int64_t* index) {
    Random random(SplitMix64(SplitMix64(options_.seed) ^ (0x5851f42d4c957f2dULL * (run + 1))));
    const int64_t run_poses =
        options_.poses / options_.runs + (run < options_.poses % options_.runs ? 1 : 0);
    const internal::RunStart start = internal::DrawRunStart(grid_, &random);
    StreetPath path(grid_, options_, start.x, start.y, start.direction, &random);
    core::Pose2 truth = start.truth;
    core::Pose2 guess = internal::RunStartGuess(options_, run, truth, &random);
    double s = 0.0;
    core::VelocityControl control;
    Eigen::Matrix3d motion_information;
    for (int64_t k = 0; k < run_poses; ++k, ++*index) {
      const double stamp = static_cast<double>(k) * options_.dt;
      GS_RETURN_IF_ERROR(
          PoseRecords(k, *index, stamp, guess, control, motion_information, log));
      // Sensing from the true pose.
      GS_RETURN_IF_ERROR(Sense(*index, truth, &random, log));
      if (options_.gps_every > 0 && k % options_.gps_every == 0) {
        std::string* line = log->line();
        AppendField(line, "GPS");
        AppendField(line, *index);
        AppendField(line, truth.x() + random.Normal(options_.gps_sigma));
        AppendField(line, truth.y() + random.Normal(options_.gps_sigma));
        AppendUpperTriangle(line, gps_information_);
        GS_RETURN_IF_ERROR(log->EndLine());
        ++summary_.gps;
      }
      GS_RETURN_IF_ERROR(TruthLine(stamp, truth));
      if (k + 1 == run_poses) continue;  // (ends the loop, counting the pose)

      // Pure pursuit on the true pose and the noisy execution, as SimulateCampus.
      control = internal::PursuitControl(options_, truth, &path, &s);
      const core::Pose2 next = internal::ExecuteWithNoise(options_, truth, control, &random);
      const Eigen::Matrix3d inverse =
          core::VelocityMotionCovariance(truth, control, options_.noise).inverse();
      motion_information = 0.5 * (inverse + inverse.transpose());
      summary_.distance_travelled += (next.head<2>() - truth.head<2>()).norm();
      truth = next;
    }
    return Status::Ok();
  }

  // POSE (with the run's initial guess at its first pose), the anchoring FIX
  // of the first pose when there is no GPS, and the motion from the previous
  // pose.
  Status PoseRecords(int64_t k, int64_t index, double stamp, const core::Pose2& guess,
                     const core::VelocityControl& control,
                     const Eigen::Matrix3d& motion_information, LogLines* log) {
    std::string* line = log->line();
    AppendField(line, "POSE");
    AppendField(line, index);
    AppendField(line, stamp);
    if (k == 0)
      for (int c = 0; c < 3; ++c) AppendField(line, guess[c]);
    GS_RETURN_IF_ERROR(log->EndLine());
    if (index == 0 && options_.gps_every == 0) {
      AppendField(line, "FIX");
      AppendField(line, index);
      GS_RETURN_IF_ERROR(log->EndLine());
    }
    if (k == 0) return Status::Ok();
    AppendField(line, "CONTROL_INFO");
    AppendField(line, index - 1);
    AppendField(line, index);
    AppendField(line, control.v);
    AppendField(line, control.omega);
    AppendField(line, control.dt);
    AppendUpperTriangle(line, motion_information);
    GS_RETURN_IF_ERROR(log->EndLine());
    ++summary_.motions;
    return Status::Ok();
  }

  // RB records of the landmarks in range and field of view of `truth`.
  Status Sense(int64_t index, const core::Pose2& truth, Random* random, LogLines* log) {
    world_.Near(truth.head<2>(), options_.sensor_range, &nearby_);
    std::string* line = log->line();
    for (const Landmark& landmark : nearby_) {
      const core::Point2 delta = landmark.position - truth.head<2>();
      const double range = delta.norm();
      if (range < min_range_ || range > options_.sensor_range) continue;
      const double bearing = core::WrapAngle(std::atan2(delta.y(), delta.x()) - truth.z());
      if (std::abs(bearing) > half_fov_) continue;
      AppendField(line, "RB");
      AppendField(line, index);
      AppendField(line, options_.feature_id_base + landmark.slot);
      AppendField(line, range + random->Normal(options_.range_sigma));
      AppendField(line, core::WrapAngle(bearing + random->Normal(options_.bearing_sigma)));
      AppendUpperTriangle(line, observation_information_);
      GS_RETURN_IF_ERROR(log->EndLine());
      uint16_t& seen = counts_[static_cast<size_t>(landmark.slot)];
      if (seen == 0) {
        ++summary_.observed_features;
        summary_.feature_id_end =
            std::max(summary_.feature_id_end, options_.feature_id_base + landmark.slot + 1);
      }
      if (seen < std::numeric_limits<uint16_t>::max()) ++seen;
      ++summary_.observations;
    }
    return Status::Ok();
  }

  Status TruthLine(double stamp, const core::Pose2& truth) {
    std::string tum_line;
    AppendField(&tum_line, stamp);
    AppendField(&tum_line, truth.x());
    AppendField(&tum_line, truth.y());
    AppendField(&tum_line, "0 0 0");
    AppendField(&tum_line, std::sin(0.5 * truth.z()));
    AppendField(&tum_line, std::cos(0.5 * truth.z()));
    tum_line.push_back('\n');
    return tum_.Append(tum_line);
  }

  const CampusSimulatorOptions& options_;
  const Grid& grid_;
  ProceduralWorld& world_;  // Near() caches segments
  std::vector<uint16_t>& counts_;
  StreamedFile& tum_;
  StreamingCampusSummary& summary_;
  const double half_fov_;
  const Eigen::Matrix2d observation_information_;
  const Eigen::Matrix2d gps_information_;
  const double min_range_;
  std::vector<Landmark> nearby_;
};

// Every landmark of the world, segment by segment, with its observation count.
Status WriteFeaturesCsv(storage::Env* env, const std::string& path,
                        const CampusSimulatorOptions& options, const ProceduralWorld& world,
                        const std::vector<uint16_t>& counts, StreamingCampusSummary* summary) {
  return storage::WriteFileAtomically(env, path, [&](storage::WritableFile* file) -> Status {
    GS_RETURN_IF_ERROR(file->Append("id,x,y,observations,excluded\n"));
    std::vector<Landmark> landmarks;
    std::string line;
    for (int64_t s = 0; s < world.NumSegmentSlots(); ++s) {
      world.Generate(s, &landmarks);
      for (const Landmark& landmark : landmarks) {
        line.clear();
        AppendField(&line, options.feature_id_base + landmark.slot);
        line.push_back(',');
        line.append(storage::internal::FormatDouble(landmark.position.x()));
        line.push_back(',');
        line.append(storage::internal::FormatDouble(landmark.position.y()));
        line.push_back(',');
        line.append(std::to_string(counts[static_cast<size_t>(landmark.slot)]));
        line.append(",0\n");
        GS_RETURN_IF_ERROR(file->Append(line));
        ++summary->landmarks;
      }
    }
    return Status::Ok();
  });
}

}  // namespace

Status SimulateCampusStreaming(const CampusSimulatorOptions& options, const std::string& dir,
                               StreamingCampusSummary* summary, int zstd_level) {
  GS_CHECK(summary != nullptr);
  GS_RETURN_IF_ERROR(options.Validate());
  *summary = StreamingCampusSummary();
  Grid grid;
  const double keep = SizeCampus(options, &grid);
  summary->grid_columns = grid.columns;
  summary->grid_rows = grid.rows;
  ProceduralWorld world(options, grid, keep);
  std::vector<uint16_t> counts(static_cast<size_t>(world.NumSlots()), 0);

  storage::Env* env = storage::Env::Default();
  const std::filesystem::path folder(dir);
  const std::string log_path =
      (folder / (zstd_level > 0 ? "log.graphslam.zst" : "log.graphslam")).string();
  const std::string tum_path = (folder / "ground_truth.tum").string();
  const std::string features_path = (folder / "ground_truth_features.csv").string();
  StreamedFile tum(env, tum_path);
  GS_RETURN_IF_ERROR(tum.Open());
  GS_RETURN_IF_ERROR(tum.Append("# timestamp x y z qx qy qz qw\n"));
  StreamingSimulation simulation(options, grid, &world, &counts, &tum, summary);
  GS_RETURN_IF_ERROR(storage::WriteFileAtomically(
      env, log_path, [&](storage::WritableFile* file) -> Status {
        LogLines log(file, zstd_level);
        return simulation.Write(&log);
      }));
  GS_RETURN_IF_ERROR(tum.Commit());
  return WriteFeaturesCsv(env, features_path, options, world, counts, summary);
}

}  // namespace graphslam::tools
