#include "storage/native_log_reader.h"

#include <tbb/parallel_pipeline.h>

#include <Eigen/LU>
#include <algorithm>
#include <atomic>
#include <functional>
#include <memory>
#include <cmath>
#include <cstring>
#include <limits>
#include <string_view>
#include <unordered_map>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "core/se2.h"
#include "core/unidentified_features.h"
#include "core/velocity_motion_model.h"
#include "storage/atomic_file.h"
#include "storage/internal/id_map.h"
#include "storage/internal/monotone_lines.h"
#include "storage/internal/problem_validation.h"
#include "storage/internal/text_blocks.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::FormatDouble;
using internal::LineReader;

// The tags ParseLine knows: the observation models' tags come from the
// registry (core/observation_models.h).
std::string KnownTags() {
  std::string tags = "POSE, FEATURE, CONTROL, CONTROL_INFO, ODOM, ";
  for (int k = 0; k < core::kNumObservationKinds; ++k)
    tags += std::string(core::NativeLogTag(static_cast<core::ObservationKind>(k))) + ", ";
  return tags + "RB_POSE, RB_POSE_INTERP, GPS, FIX or SCAN";
}

}  // namespace

void SizeGuesses(core::Problem2d* problem);

namespace {

class NativeLogParser {
 public:
  static constexpr int64_t kBlockBytes = int64_t{1} << 20;
  static constexpr size_t kBlocksInFlight = 4;

  explicit NativeLogParser(const std::string& path, const ObservationSink* sink = nullptr,
                           std::vector<NativeLogScan>* scans = nullptr,
                           core::InformationRepairs* repairs = nullptr,
                           bool skip_features = false)
      : path_(path), sink_(sink), scans_(scans), repairs_(repairs),
        skip_features_(skip_features) {}

  // false: a log without FEATURE guesses is returned with `features` and
  // `feature_initialized` empty (ReadNativeLogStreaming's `size_guesses`).
  void SizeGuessesAtTheEnd(bool size) { size_guesses_ = size; }

  // Dense indices are int32: a larger figure is not a real log's. Reserved
  // pages are resident only once written: the guesses and flags of a log
  // without FEATURE guesses are written after the id table is freed.
  void Reserve(const ExpectedSizes& expected) {
    constexpr int64_t kMost = std::numeric_limits<int32_t>::max();
    declared_once_ = expected.declared_once;
    if (expected.features <= 0 || expected.features > kMost) return;
    const auto features = static_cast<size_t>(expected.features);
    problem_.features.reserve(features);
    problem_.feature_ids.reserve(features);
    problem_.feature_initialized.reserve(features);
    if (declared_once_) return;  // no per-feature state of the checks
    feature_lines_.Reserve(expected.features);
    feature_declared_.reserve(features);
    if (expected.feature_id_end > 0 && expected.feature_id_end <= kMost)
      features_.ReserveDirect(expected.feature_id_end, expected.features);
  }

  // Lines are cut into blocks and tokenized (fields split, numbers
  // converted) in parallel; the records are then interpreted in file order,
  // so ids, dense indices, checks and messages are those of a serial read.
  StatusOr<core::Problem2d> Parse() {
    GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::TextBlockCutter> cutter,
                        internal::TextBlockCutter::Open(path_, 0, 0, kBlockBytes));
    const std::unique_ptr<LineReader> reader = LineReader::ForTokenizedLines(path_);
    problem_.source = path_;
    bool header = false;
    Status read_failure;              // first stage only
    Status parse_failure;             // last stage only
    std::atomic<bool> failed{false};  // read by the first stage, set by both
    internal::BlockPool<internal::TextBlock> pool;  // kBlocksInFlight blocks, reused
    tbb::parallel_pipeline(
        kBlocksInFlight,
        tbb::make_filter<void, internal::TextBlock*>(
            tbb::filter_mode::serial_in_order,
            [&](tbb::flow_control& control) -> internal::TextBlock* {
              std::unique_ptr<internal::TextBlock> block = pool.Take();
              if (failed || !cutter->Next(block.get(), &read_failure)) {
                if (!read_failure.ok()) failed = true;
                control.stop();
                return nullptr;
              }
              return block.release();
            }) &
            tbb::make_filter<internal::TextBlock*, internal::TextBlock*>(
                tbb::filter_mode::parallel,
                [](internal::TextBlock* block) {
                  internal::TokenizeBlock(block);
                  return block;
                }) &
            tbb::make_filter<internal::TextBlock*, void>(
                tbb::filter_mode::serial_in_order, [&](internal::TextBlock* raw) {
                  std::unique_ptr<internal::TextBlock> block(raw);
                  struct Recycle {
                    internal::BlockPool<internal::TextBlock>* pool;
                    std::unique_ptr<internal::TextBlock>* block;
                    ~Recycle() { pool->Give(std::move(*block)); }
                  } recycle{&pool, &block};
                  if (failed) return;
                  for (const internal::TokenizedLine& line : block->lines) {
                    reader->Adopt(line);
                    Status status = header ? ParseLine(*reader) : ParseHeader(*reader);
                    header = true;
                    if (!status.ok()) {
                      parse_failure = std::move(status);
                      failed = true;
                      return;
                    }
                  }
                }));
    if (!parse_failure.ok()) return parse_failure;
    if (!read_failure.ok()) return read_failure;
    if (!header) {
      return Status::Corruption(reader->name() + ": is empty; expected the header " +
                                kNativeLogMagic + " " + std::to_string(kNativeLogVersion));
    }
    // The per-feature state of the checks goes before the guesses come:
    // the id table, lines and flags are never resident with them.
    features_ = internal::GrowingIdMap();
    feature_lines_ = internal::MonotoneLines();
    feature_declared_ = std::vector<bool>();
    if (guesses_held_ || size_guesses_) SizeGuesses(&problem_);
    return std::move(problem_);
  }

 private:
  Status ParseHeader(const LineReader& reader) {
    const auto& fields = reader.fields();
    if (fields[0] != kNativeLogMagic) {
      return reader.Error("first record is '" + std::string(fields[0]) +
                          "'; expected the header " + kNativeLogMagic + " " +
                          std::to_string(kNativeLogVersion));
    }
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(2));
    GS_ASSIGN_OR_RETURN(const int64_t version, reader.Id(1, "version"));
    if (version != kNativeLogVersion) {
      return reader.Unsupported("format version " + std::to_string(version) + "; expected " +
                                std::to_string(kNativeLogVersion));
    }
    return Status::Ok();
  }

  Status ParseLine(const LineReader& reader) {
    const std::string_view tag = reader.fields()[0];
    if (tag == "POSE") return ParsePose(reader);
    if (tag == "FEATURE") return ParseFeature(reader);
    if (tag == "CONTROL") return ParseControl(reader, /*explicit_information=*/false);
    if (tag == "CONTROL_INFO") return ParseControl(reader, /*explicit_information=*/true);
    if (tag == "ODOM") return ParseOdometry(reader);
    core::ObservationKind kind;
    if (core::ObservationKindOfNativeLogTag(tag, &kind)) return ParseObservation(reader, kind);
    if (tag == "GPS") return ParseGps(reader);
    if (tag == "RB_POSE") return ParsePoseRangeBearing(reader);
    if (tag == "RB_POSE_INTERP") return ParseInterpolatedPoseRangeBearing(reader);
    if (tag == "FIX") return ParseFix(reader);
    if (tag == "SCAN") return ParseScan(reader);
    if (tag == kNativeLogMagic) {
      return reader.Error("a second header; expected one header, on the first line");
    }
    return reader.Unsupported("unknown tag '" + std::string(tag) + "'; expected " + KnownTags());
  }

  Status ParsePose(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(3, 6));
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "id"));
    double stamp = std::numeric_limits<double>::quiet_NaN();
    if (reader.fields()[2] != "-") {
      GS_ASSIGN_OR_RETURN(stamp, reader.Double(2, "time", internal::Magnitude::kTime));
    }
    const bool initialized = reader.fields().size() == 6;
    double guess[3] = {0.0, 0.0, 0.0};
    if (initialized) GS_RETURN_IF_ERROR(reader.Doubles(3, 3, "initial guess", guess));
    if (const int32_t known = poses_.Find(id); known >= 0) {
      return reader.Error("POSE " + std::to_string(id) + " is already declared at line " +
                          std::to_string(problem_.pose_lines[known]) +
                          "; expected unique pose ids");
    }
    poses_.Insert(id, problem_.AddPose(id, core::Pose2(guess[0], guess[1], guess[2]),
                                        initialized, reader.line_number(), stamp));
    reached_.push_back(initialized ? 1 : 0);
    return Status::Ok();
  }

  Status ParseFeature(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(2, 4));
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "id"));
    if (skip_features_) return Status::Ok();
    const bool initialized = reader.fields().size() == 4;
    double guess[2] = {0.0, 0.0};
    if (initialized) GS_RETURN_IF_ERROR(reader.Doubles(2, 2, "initial guess", guess));
    if (declared_once_) {
      NewFeature(id, initialized ? guess : nullptr);
      return Status::Ok();
    }
    if (const int32_t known = features_.Find(id); known >= 0) {
      const int32_t line = feature_lines_[known];
      return reader.Error(
          "FEATURE " + std::to_string(id) +
          (feature_declared_[known] ? " is already declared at line "
                                    : " comes after its first use at line ") +
          std::to_string(line) + "; expected one FEATURE record, before the feature's first use");
    }
    features_.Insert(id, NewFeature(id, initialized ? guess : nullptr));
    feature_lines_.Append(reader.line_number());
    feature_declared_.push_back(true);
    return Status::Ok();
  }

  // Appends a feature (its id; its guess only once some feature has one)
  // and returns its dense index. Until the first FEATURE record with a
  // guess, problem_.features and feature_initialized stay empty (Parse
  // sizes them at the end): a log whose features are all placed by the
  // initialization holds 8 B per feature while it is read, not 25.
  int32_t NewFeature(int64_t id, const double* guess) {
    if (guess != nullptr && !guesses_held_) {
      guesses_held_ = true;
      SizeGuesses(&problem_);
    }
    problem_.feature_ids.push_back(id);
    if (guesses_held_) {
      problem_.features.push_back(guess != nullptr ? core::Point2(guess[0], guess[1])
                                                   : core::Point2::Zero());
      problem_.feature_initialized.push_back(guess != nullptr ? 1 : 0);
    }
    return static_cast<int32_t>(problem_.feature_ids.size() - 1);
  }

  StatusOr<int32_t> Pose(const LineReader& reader, size_t field) {
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(field, "pose id"));
    const int32_t pose = poses_.Find(id);
    if (pose < 0) {
      return reader.Error(std::string(reader.fields()[0]) + " refers to pose " +
                          std::to_string(id) +
                          ", which no earlier POSE record declares; expected POSE " +
                          std::to_string(id) + " first");
    }
    return pose;
  }

  StatusOr<int32_t> Feature(const LineReader& reader, size_t field) {
    // Without the id table no reference can be resolved.
    if (declared_once_)
      return reader.Error(std::string(reader.fields()[0]) +
                          " refers to a feature; expected no record that does (a chunk "
                          "store's problem file holds no observations)");
    if (reader.fields()[field] == "-") {
      // Unknown correspondence: a feature of its own, for data association.
      const int32_t feature = NewFeature(core::kNoFeatureId, nullptr);
      feature_lines_.Append(reader.line_number());
      feature_declared_.push_back(false);
      return feature;
    }
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(field, "feature id"));
    if (const int32_t known = features_.Find(id); known >= 0) return known;
    const int32_t feature = NewFeature(id, nullptr);
    features_.Insert(id, feature);
    feature_lines_.Append(reader.line_number());
    feature_declared_.push_back(false);
    return feature;
  }

  // Reads `from` and `to` and rejects self-loops.
  Status PosePair(const LineReader& reader, int32_t* from, int32_t* to) {
    GS_ASSIGN_OR_RETURN(*from, Pose(reader, 1));
    GS_ASSIGN_OR_RETURN(*to, Pose(reader, 2));
    if (*from == *to) {
      return reader.Error(std::string(reader.fields()[0]) + " connects pose " +
                          std::string(reader.fields()[1]) +
                          " to itself; expected two distinct poses");
    }
    return Status::Ok();
  }

  StatusOr<Eigen::Matrix3d> Information3(const LineReader& reader, size_t first) {
    double upper[6];
    GS_RETURN_IF_ERROR(reader.Doubles(first, 6, "information", upper,
                                       internal::Magnitude::kInformation));
    Eigen::Matrix3d information = internal::SymmetricFromUpper3(upper);
    if (!internal::IsPositiveDefinite(information) &&
        !core::RepairAndCount(repairs_, reader.line_number(), &information)) {
      return reader.Error(std::string(reader.fields()[0]) + " information " +
                          internal::UpperTriangleString(upper, 6) +
                          " is not positive definite; expected a symmetric positive definite "
                          "matrix (i11 i12 i13 i22 i23 i33)");
    }
    return information;
  }

  StatusOr<Eigen::Matrix2d> Information2(const LineReader& reader, size_t first) {
    double upper[3];
    GS_RETURN_IF_ERROR(reader.Doubles(first, 3, "information", upper,
                                       internal::Magnitude::kInformation));
    Eigen::Matrix2d information = internal::SymmetricFromUpper2(upper);
    // Records repeat their information: the bits of the last definite one
    // need no second factorization.
    if (std::memcmp(upper, last_definite2_, sizeof(upper)) == 0) return information;
    if (internal::IsPositiveDefinite(information)) {
      std::memcpy(last_definite2_, upper, sizeof(upper));
      return information;
    }
    if (!core::RepairAndCount(repairs_, reader.line_number(), &information)) {
      return reader.Error(std::string(reader.fields()[0]) + " information " +
                          internal::UpperTriangleString(upper, 3) +
                          " is not positive definite; expected a symmetric positive definite "
                          "matrix (i11 i12 i22)");
    }
    return information;
  }

  // The information of a 1-D measurement: one positive number.
  StatusOr<double> Information1(const LineReader& reader, size_t first) {
    double w = 0.0;
    GS_RETURN_IF_ERROR(
        reader.Doubles(first, 1, "information", &w, internal::Magnitude::kInformation));
    if (!(w > 0.0) && !core::RepairAndCount(repairs_, reader.line_number(), &w)) {
      return reader.Error(std::string(reader.fields()[0]) + " information " + FormatDouble(w) +
                          " is not positive; expected a positive number (i11)");
    }
    return w;
  }

  // Spec rule 3: the first constraint reaching an uninitialized pose sets its
  // value (the linearization point of later CONTROL records).
  void Reach(int32_t to, const core::Pose2& predicted) {
    if (reached_[to]) return;
    reached_[to] = 1;
    problem_.poses[to] = predicted;
  }

  Status ParseControl(const LineReader& reader, bool explicit_information) {
    if (explicit_information) {
      GS_RETURN_IF_ERROR(reader.ExpectFieldCount(12));
    } else {
      GS_RETURN_IF_ERROR(reader.ExpectFieldCount(6, 12));
    }
    core::VelocityMotionConstraint motion;
    GS_RETURN_IF_ERROR(PosePair(reader, &motion.from, &motion.to));
    GS_ASSIGN_OR_RETURN(motion.control.v, reader.Double(3, "v"));
    GS_ASSIGN_OR_RETURN(motion.control.omega, reader.Double(4, "omega"));
    GS_ASSIGN_OR_RETURN(motion.control.dt, reader.Double(5, "dt"));
    if (motion.control.dt < 0.0) {
      return reader.Error(std::string(reader.fields()[0]) + " dt is " +
                          FormatDouble(motion.control.dt) + "; expected dt >= 0");
    }
    const core::Pose2& previous = problem_.poses[motion.from];
    if (explicit_information) {
      GS_ASSIGN_OR_RETURN(motion.information, Information3(reader, 6));
    } else {
      core::VelocityNoise noise;
      if (reader.fields().size() == 12) {
        GS_RETURN_IF_ERROR(reader.Doubles(6, 6, "noise alpha", noise.alpha));
        for (double alpha : noise.alpha) {
          if (alpha < 0.0) {
            return reader.Error("CONTROL noise alpha " + FormatDouble(alpha) +
                                " is negative; expected alphas >= 0");
          }
        }
      }
      motion.information =
          core::VelocityMotionCovariance(previous, motion.control, noise).inverse();
      if (!internal::IsPositiveDefinite(motion.information)) {
        return reader.Error(
            "CONTROL motion information (inverse of the velocity motion covariance) is not "
            "positive definite; expected the noise floor to keep it definite");
      }
    }
    motion.line = reader.line_number();
    Reach(motion.to, core::PredictVelocityMotion(previous, motion.control));
    problem_.motions.push_back(motion);
    return Status::Ok();
  }

  Status ParseOdometry(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(12));
    core::RelativePoseConstraint constraint;
    GS_RETURN_IF_ERROR(PosePair(reader, &constraint.from, &constraint.to));
    double z[3];
    GS_RETURN_IF_ERROR(reader.Doubles(3, 3, "measurement", z));
    constraint.z = core::Pose2(z[0], z[1], z[2]);
    GS_ASSIGN_OR_RETURN(constraint.information, Information3(reader, 6));
    constraint.line = reader.line_number();
    Reach(constraint.to, core::Compose(problem_.poses[constraint.from], constraint.z));
    problem_.relative_poses.push_back(constraint);
    return Status::Ok();
  }

  // TAG pose feature z[m] upper(information)[m (m + 1) / 2], m the model's
  // measurement dimension; a 1-D model's record is padded to the 2-D slot as
  // core/observation_models.h says.
  Status ParseObservation(const LineReader& reader, core::ObservationKind kind) {
    const int dim = core::MeasurementDim(kind);
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(static_cast<size_t>(3 + dim + dim * (dim + 1) / 2)));
    core::Observation observation;
    GS_ASSIGN_OR_RETURN(observation.pose, Pose(reader, 1));
    double z[2] = {0.0, 0.0};
    GS_RETURN_IF_ERROR(reader.Doubles(3, static_cast<size_t>(dim), "measurement", z));
    observation.z = Eigen::Vector2d(z[0], z[1]);
    const int invalid = core::InvalidMeasurementField(kind, observation.z);
    if (invalid >= 0) {
      return reader.Error(std::string(reader.fields()[0]) + " " +
                          core::MeasurementFieldName(kind, invalid) + " is " +
                          FormatDouble(z[invalid]) + "; expected " +
                          core::MeasurementRule(kind));
    }
    const size_t information_at = static_cast<size_t>(3 + dim);
    if (dim == 2) {
      GS_ASSIGN_OR_RETURN(observation.information, Information2(reader, information_at));
    } else {
      GS_ASSIGN_OR_RETURN(const double w, Information1(reader, information_at));
      observation.information = Eigen::Vector2d(w, 1.0).asDiagonal();
    }
    GS_ASSIGN_OR_RETURN(observation.feature, Feature(reader, 2));
    observation.kind = kind;
    observation.line = reader.line_number();
    // Streaming (ReadNativeLogStreaming): the observation goes to the sink,
    // the problem keeps O(poses + features).
    if (sink_ != nullptr) return (*sink_)(observation);
    problem_.observations.push_back(observation);
    return Status::Ok();
  }

  Status ParseGps(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(7));
    core::GpsConstraint gps;
    GS_ASSIGN_OR_RETURN(gps.pose, Pose(reader, 1));
    double z[2];
    GS_RETURN_IF_ERROR(reader.Doubles(2, 2, "position", z));
    gps.z = Eigen::Vector2d(z[0], z[1]);
    GS_ASSIGN_OR_RETURN(gps.information, Information2(reader, 4));
    gps.line = reader.line_number();
    problem_.gps.push_back(gps);
    return Status::Ok();
  }

  // RB_POSE from to range bearing i11 i12 i22: pose `to` seen from pose `from`.
  Status ParsePoseRangeBearing(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(8));
    core::PoseRangeBearingConstraint constraint;
    GS_RETURN_IF_ERROR(PosePair(reader, &constraint.from, &constraint.to));
    double z[2];
    GS_RETURN_IF_ERROR(reader.Doubles(3, 2, "measurement", z));
    if (!(z[0] > 0.0)) {
      return reader.Error("RB_POSE range is " + FormatDouble(z[0]) + "; expected range > 0");
    }
    constraint.z = Eigen::Vector2d(z[0], z[1]);
    GS_ASSIGN_OR_RETURN(constraint.information, Information2(reader, 5));
    constraint.line = reader.line_number();
    problem_.pose_range_bearings.push_back(constraint);
    return Status::Ok();
  }

  // RB_POSE_INTERP from to to_next alpha range bearing i11 i12 i22: the
  // position interpolated at alpha between poses `to` and `to_next`, seen
  // from pose `from`.
  Status ParseInterpolatedPoseRangeBearing(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(10));
    core::PoseRangeBearingConstraint constraint;
    GS_RETURN_IF_ERROR(PosePair(reader, &constraint.from, &constraint.to));
    GS_ASSIGN_OR_RETURN(constraint.to_next, Pose(reader, 3));
    if (constraint.to_next == constraint.from || constraint.to_next == constraint.to) {
      return reader.Error("RB_POSE_INTERP pose " + std::string(reader.fields()[3]) +
                          " repeats pose " + std::string(reader.fields()[1]) + " or " +
                          std::string(reader.fields()[2]) + "; expected three distinct poses");
    }
    GS_ASSIGN_OR_RETURN(constraint.alpha, reader.Double(4, "alpha"));
    if (!(constraint.alpha >= 0.0 && constraint.alpha <= 1.0)) {
      return reader.Error("RB_POSE_INTERP alpha is " + FormatDouble(constraint.alpha) +
                          "; expected 0 <= alpha <= 1");
    }
    double z[2];
    GS_RETURN_IF_ERROR(reader.Doubles(5, 2, "measurement", z));
    if (!(z[0] > 0.0)) {
      return reader.Error("RB_POSE_INTERP range is " + FormatDouble(z[0]) +
                          "; expected range > 0");
    }
    constraint.z = Eigen::Vector2d(z[0], z[1]);
    GS_ASSIGN_OR_RETURN(constraint.information, Information2(reader, 7));
    constraint.line = reader.line_number();
    problem_.pose_range_bearings.push_back(constraint);
    return Status::Ok();
  }

  Status ParseFix(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(2));
    GS_ASSIGN_OR_RETURN(const int32_t pose, Pose(reader, 1));
    problem_.pose_fixed[pose] = 1;
    return Status::Ok();
  }

  // SCAN pose file: checked here, kept only for ReadNativeLogScans (the
  // solver does not use scans).
  Status ParseScan(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(3));
    GS_ASSIGN_OR_RETURN(const int32_t pose, Pose(reader, 1));
    if (scans_ != nullptr)
      scans_->push_back({pose, std::string(reader.fields()[2]), reader.line_number()});
    return Status::Ok();
  }

  const std::string path_;
  const ObservationSink* sink_ = nullptr;
  std::vector<NativeLogScan>* scans_ = nullptr;
  core::InformationRepairs* repairs_ = nullptr;  // null: reject non-PD information
  const bool skip_features_ = false;
  core::Problem2d problem_;
  internal::GrowingIdMap poses_;     // dense ids: a direct table (one look-up per record)
  internal::GrowingIdMap features_;  // dense ids: a direct table
  std::vector<uint8_t> reached_;          // per pose: has a value (guess or prediction)
  // Per feature, for the FEATURE-record rules and their messages:
  internal::MonotoneLines feature_lines_;  // declaration or first use (file order)
  std::vector<bool> feature_declared_;     // by a FEATURE record
  // Information2's last positive definite upper triangle (NaN: none yet;
  // its bits never equal a parsed, finite number's).
  double last_definite2_[3] = {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0};
  bool guesses_held_ = false;              // NewFeature
  bool declared_once_ = false;             // ExpectedSizes::declared_once
  bool size_guesses_ = true;
};

}  // namespace

void SizeGuesses(core::Problem2d* problem) {
  problem->features.resize(problem->feature_ids.size(), core::Point2::Zero());
  problem->feature_initialized.resize(problem->feature_ids.size(), 0);
}

namespace {

// The parser's id maps die with it: a std::unordered_map node per feature
// (~48 B each, small heap chunks). glibc keeps freed small chunks in its heap,
// resident, so a 4.3 M-feature read left ~200 MB of free memory in the RSS
// of the ingest and of every solve of the store. malloc_trim(0) gives the
// free pages back (madvise); done only for large problems (it walks the heap).
StatusOr<core::Problem2d> ReleasingFreedMemory(StatusOr<core::Problem2d> read) {
#ifdef __GLIBC__
  constexpr int64_t kTrimAbove = 1 << 20;  // poses + features
  if (read.ok() && int64_t{read->num_poses()} + read->num_features() >= kTrimAbove)
    malloc_trim(0);
#endif
  return read;
}

}  // namespace

StatusOr<core::Problem2d> ReadNativeLog(const std::string& path,
                                        core::InformationRepairs* repairs) {
  return ReleasingFreedMemory(NativeLogParser(path, nullptr, nullptr, repairs).Parse());
}

StatusOr<core::Problem2d> ReadNativeLogWithoutFeatures(const std::string& path) {
  return ReleasingFreedMemory(NativeLogParser(path, nullptr, nullptr, nullptr, true).Parse());
}

StatusOr<core::Problem2d> ReadNativeLog(const std::string& path,
                                        std::vector<NativeLogScan>* scans,
                                        core::InformationRepairs* repairs) {
  scans->clear();
  return ReleasingFreedMemory(NativeLogParser(path, nullptr, scans, repairs).Parse());
}

StatusOr<core::Problem2d> ReadNativeLogStreaming(const std::string& path,
                                                 const ObservationSink& sink,
                                                 std::vector<NativeLogScan>* scans,
                                                 const ExpectedSizes& expected,
                                                 bool size_guesses) {
  if (scans != nullptr) scans->clear();
  NativeLogParser parser(path, &sink, scans);
  parser.Reserve(expected);
  parser.SizeGuessesAtTheEnd(size_guesses);
  return ReleasingFreedMemory(parser.Parse());
}

namespace {

// Appends records [0, n) to `file` in order, each formatted by
// format(i, &text) (which appends one or more whole lines), formatting blocks
// of records in parallel (TBB): %.17g formatting is most of the cost of
// writing a large problem, and the bytes do not depend on the threads.
Status AppendRecords(WritableFile* file, int64_t n,
                     const std::function<void(int64_t, std::string*)>& format) {
  constexpr int64_t kRecordsPerBlock = 8192;
  struct Block {
    int64_t begin = 0, end = 0;
    std::string text;
  };
  int64_t next = 0;
  Status status;
  tbb::parallel_pipeline(
      8,
      tbb::make_filter<void, Block*>(tbb::filter_mode::serial_in_order,
                                     [&](tbb::flow_control& control) -> Block* {
                                       if (next >= n || !status.ok()) {
                                         control.stop();
                                         return nullptr;
                                       }
                                       auto block = std::make_unique<Block>();
                                       block->begin = next;
                                       block->end = std::min(n, next + kRecordsPerBlock);
                                       next = block->end;
                                       return block.release();
                                     }) &
          tbb::make_filter<Block*, Block*>(tbb::filter_mode::parallel,
                                           [&](Block* block) -> Block* {
                                             for (int64_t i = block->begin; i < block->end; ++i)
                                               format(i, &block->text);
                                             return block;
                                           }) &
          tbb::make_filter<Block*, void>(tbb::filter_mode::serial_in_order, [&](Block* raw) {
            std::unique_ptr<Block> block(raw);
            if (status.ok()) status = file->Append(block->text);
          }));
  return status;
}

// One record of each type, appended to *out as one line without its newline
// (AppendField starts a field with a space unless the string is empty).
using RecordFormatter = void (*)(const core::Problem2d&, int64_t, std::string*);

void AppendPoseRecord(const core::Problem2d& problem, int64_t i, std::string* out) {
  using internal::AppendField;
  AppendField(out, "POSE");
  AppendField(out, problem.pose_ids[i]);
  const double stamp = problem.pose_stamps[i];
  if (std::isnan(stamp)) {
    AppendField(out, "-");
  } else {
    AppendField(out, stamp);
  }
  if (problem.pose_initialized[i]) {
    for (int k = 0; k < 3; ++k) AppendField(out, problem.poses[i][k]);
  }
}

void AppendFeatureRecord(const core::Problem2d& problem, int64_t i, std::string* out) {
  using internal::AppendField;
  AppendField(out, "FEATURE");
  AppendField(out, problem.feature_ids[i]);
  if (problem.feature_initialized[i]) {
    AppendField(out, problem.features[i].x());
    AppendField(out, problem.features[i].y());
  }
}

void AppendMotionRecord(const core::Problem2d& problem, int64_t i, std::string* out) {
  using internal::AppendField;
  const auto& motion = problem.motions[static_cast<size_t>(i)];
  AppendField(out, "CONTROL_INFO");
  AppendField(out, problem.pose_ids[motion.from]);
  AppendField(out, problem.pose_ids[motion.to]);
  AppendField(out, motion.control.v);
  AppendField(out, motion.control.omega);
  AppendField(out, motion.control.dt);
  internal::AppendUpperTriangle(out, motion.information);
}

void AppendOdometryRecord(const core::Problem2d& problem, int64_t i, std::string* out) {
  using internal::AppendField;
  const auto& constraint = problem.relative_poses[static_cast<size_t>(i)];
  AppendField(out, "ODOM");
  AppendField(out, problem.pose_ids[constraint.from]);
  AppendField(out, problem.pose_ids[constraint.to]);
  for (int k = 0; k < 3; ++k) AppendField(out, constraint.z[k]);
  internal::AppendUpperTriangle(out, constraint.information);
}

// The record layout of the observation's model (core/observation_models.h):
// TAG pose feature z[dim] information-upper-triangle.
void AppendObservationRecord(const core::Problem2d& problem, int64_t i, std::string* out) {
  using internal::AppendField;
  const auto& observation = problem.observations[static_cast<size_t>(i)];
  const int dim = core::MeasurementDim(observation.kind);
  AppendField(out, core::NativeLogTag(observation.kind));
  AppendField(out, problem.pose_ids[observation.pose]);
  AppendField(out, problem.feature_ids[observation.feature]);
  for (int k = 0; k < dim; ++k) AppendField(out, observation.z[k]);
  if (dim == 2) {
    internal::AppendUpperTriangle(out, observation.information);
  } else {
    AppendField(out, observation.information(0, 0));
  }
}

void AppendGpsRecord(const core::Problem2d& problem, int64_t i, std::string* out) {
  using internal::AppendField;
  const auto& gps = problem.gps[static_cast<size_t>(i)];
  AppendField(out, "GPS");
  AppendField(out, problem.pose_ids[gps.pose]);
  AppendField(out, gps.z.x());
  AppendField(out, gps.z.y());
  internal::AppendUpperTriangle(out, gps.information);
}

void AppendRobotSightingRecord(const core::Problem2d& problem, int64_t i, std::string* out) {
  using internal::AppendField;
  const auto& c = problem.pose_range_bearings[static_cast<size_t>(i)];
  AppendField(out, c.interpolated() ? "RB_POSE_INTERP" : "RB_POSE");
  AppendField(out, problem.pose_ids[c.from]);
  AppendField(out, problem.pose_ids[c.to]);
  if (c.interpolated()) {
    AppendField(out, problem.pose_ids[c.to_next]);
    AppendField(out, c.alpha);
  }
  AppendField(out, c.z.x());
  AppendField(out, c.z.y());
  internal::AppendUpperTriangle(out, c.information);
}

// Records [0, n) of one type, a line each (AppendRecords).
Status AppendLines(WritableFile* file, const core::Problem2d& problem, size_t n,
                   RecordFormatter record) {
  return AppendRecords(file, static_cast<int64_t>(n),
                       [&problem, record](int64_t i, std::string* text) {
                         std::string one;
                         record(problem, i, &one);
                         if (one.empty()) return;
                         text->append(one);
                         text->push_back('\n');
                       });
}

// The magic and version line, then where the problem came from.
Status AppendHeader(WritableFile* file, const core::Problem2d& problem) {
  using internal::AppendField;
  // A field starts with a space unless the string is empty: one string a line.
  std::string magic, comment;
  AppendField(&magic, kNativeLogMagic);
  AppendField(&magic, static_cast<int64_t>(kNativeLogVersion));
  AppendField(&comment, "# written by graphslam from");
  AppendField(&comment, problem.source.empty() ? std::string_view("memory") : problem.source);
  AppendField(&comment, "(spec: docs/formats/native_log.md)");
  return file->Append(magic + "\n" + comment + "\n");
}

Status AppendFixes(WritableFile* file, const core::Problem2d& problem) {
  std::string lines;
  for (int32_t i = 0; i < problem.num_poses(); ++i) {
    if (!problem.pose_fixed[i]) continue;
    std::string line;  // AppendField: no leading space on an empty string
    internal::AppendField(&line, "FIX");
    internal::AppendField(&line, problem.pose_ids[i]);
    lines += line;
    lines.push_back('\n');
  }
  return lines.empty() ? Status::Ok() : file->Append(lines);
}

// Every record of `problem`, in the order of docs/formats/native_log.md.
Status AppendNativeLog(WritableFile* file, const core::Problem2d& problem) {
  GS_RETURN_IF_ERROR(AppendHeader(file, problem));
  GS_RETURN_IF_ERROR(AppendLines(file, problem, problem.poses.size(), AppendPoseRecord));
  GS_RETURN_IF_ERROR(AppendLines(file, problem, problem.features.size(), AppendFeatureRecord));
  GS_RETURN_IF_ERROR(AppendFixes(file, problem));
  GS_RETURN_IF_ERROR(AppendLines(file, problem, problem.motions.size(), AppendMotionRecord));
  GS_RETURN_IF_ERROR(
      AppendLines(file, problem, problem.relative_poses.size(), AppendOdometryRecord));
  GS_RETURN_IF_ERROR(
      AppendLines(file, problem, problem.observations.size(), AppendObservationRecord));
  GS_RETURN_IF_ERROR(AppendLines(file, problem, problem.gps.size(), AppendGpsRecord));
  return AppendLines(file, problem, problem.pose_range_bearings.size(),
                     AppendRobotSightingRecord);
}

}  // namespace

Status WriteNativeLog(const core::Problem2d& problem, const std::string& path, Env* env) {
  GS_RETURN_IF_ERROR(
      internal::ValidateProblemForWriting(problem, /*shared_id_space=*/false)
          .WithContext("writing " + path));
  if (env == nullptr) env = Env::Default();
  return WriteFileAtomically(env, path, [&problem](WritableFile* file) -> Status {
    return AppendNativeLog(file, problem);
  });
}

}  // namespace graphslam::storage
