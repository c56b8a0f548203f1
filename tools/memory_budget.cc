#include "tools/memory_budget.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string_view>
#include <vector>

#include "core/problem.h"
#include "storage/compressed_file.h"
#include "storage/env.h"
#include "storage/native_log_counts.h"

namespace graphslam::tools {

namespace {

// Missing or unreadable inputs are I/O errors here (exit 3), as the
// estimates are made before any reader has looked at the input.
Status AsIOError(const Status& status) {
  return status.IsIOError() ? status : Status::IOError(status.message());
}

// Bytes of the directory tree or file at `path` (an MRCLAM input is a folder).
StatusOr<int64_t> InputBytes(storage::Env* env, const std::string& path) {
  if (env->KindOf(path) == storage::FileKind::kDirectory) {
    StatusOr<std::vector<std::string>> files = env->ListTree(path);
    if (!files.ok()) return AsIOError(files.status());
    int64_t total = 0;
    for (const std::string& file : *files) {
      StatusOr<uint64_t> bytes = env->FileSize(path + "/" + file);
      if (!bytes.ok()) return AsIOError(bytes.status());
      total += static_cast<int64_t>(*bytes);
    }
    return total;
  }
  StatusOr<uint64_t> bytes = env->FileSize(path);
  if (!bytes.ok()) return AsIOError(bytes.status());
  return static_cast<int64_t>(*bytes);
}

}  // namespace

StatusOr<RecordCounts> CountPoseAndFeatureRecords(const std::string& path) {
  StatusOr<std::unique_ptr<storage::ReadableFile>> file =
      storage::Env::Default()->NewReadableFile(path);
  if (!file.ok()) return AsIOError(file.status());
  constexpr std::string_view kPose = "\nPOSE ";
  constexpr std::string_view kFeature = "\nFEATURE ";
  constexpr size_t kBlock = size_t{1} << 20;
  // The file's start is a line start; the last bytes of a block (one less
  // than the longer record) are kept so that a record split between two
  // reads is still found, and counted once: only a match that ends past the
  // kept bytes is new.
  std::string buffer = "\n";
  buffer.reserve(kBlock + kFeature.size());
  RecordCounts counts;
  const auto count = [](std::string_view text, std::string_view record, size_t kept) {
    int64_t n = 0;
    for (size_t at = text.find(record); at != std::string_view::npos;
         at = text.find(record, at + 1))
      if (at + record.size() > kept) ++n;
    return n;
  };
  for (size_t kept = 0;;) {
    const size_t held = buffer.size();
    buffer.resize(held + kBlock);
    GS_ASSIGN_OR_RETURN(const size_t got, (*file)->Read(kBlock, buffer.data() + held));
    buffer.resize(held + got);
    counts.poses += count(buffer, kPose, kept);
    counts.features += count(buffer, kFeature, kept);
    if (got < kBlock) break;
    kept = std::min(buffer.size(), kFeature.size() - 1);
    buffer.erase(0, buffer.size() - kept);
  }
  return counts;
}

std::string FormatBytes(int64_t bytes) {
  char text[32];
  if (bytes >= (int64_t{1} << 30))
    std::snprintf(text, sizeof(text), "%.2f GiB", static_cast<double>(bytes) / (1 << 30));
  else
    std::snprintf(text, sizeof(text), "%.1f MiB", static_cast<double>(bytes) / (1 << 20));
  return text;
}

std::string BelowNeed(const std::string& option, int64_t limit_bytes, const std::string& need,
                      int64_t need_bytes) {
  return option + " " + FormatBytes(limit_bytes) + " is below the " + need + " of " +
         FormatBytes(need_bytes) + " (" + std::to_string(need_bytes) +
         " bytes): the smallest limit that works";
}

int64_t IngestInput::FixedBytes() const {
  return kIngestBaseBytes + std::min(kIngestBlockBytes, input_bytes / 4);
}

int64_t IngestInput::Pass1FeatureBytes() const {
  if (counted && feature_id_end >= 0)
    return std::max(features * kIngestPass1BytesPerFeature +
                        feature_id_end * kIngestBytesPerFeatureId,
                    features * kIngestHeldBytesPerFeature);
  return features * kIngestPass1BytesPerFeatureUnknownIds;
}

storage::ExpectedSizes IngestInput::Expected() const {
  if (!counted) return {};
  return {features, feature_id_end};
}

StatusOr<IngestInput> EstimateIngestInput(const std::string& path, storage::InputFormat format) {
  IngestInput input;
  GS_ASSIGN_OR_RETURN(input.input_bytes, InputBytes(storage::Env::Default(), path));
  input.streamed = format == storage::InputFormat::kNative;
  if (!input.streamed) return input;
  if (storage::IsZstdFile(path)) input.input_bytes = input.input_bytes / 100 * kZstdLogRatioPercent;
  // Exact counts when the log ends with them; its size at the simulator's
  // proportions otherwise.
  const StatusOr<storage::NativeLogCounts> counts = storage::ReadNativeLogCounts(path);
  if (!counts.ok() && counts.status().code() != Status::Code::kNotFound) return counts.status();
  input.counted = counts.ok();
  input.observations =
      counts.ok() ? counts->observations : input.input_bytes / kLogBytesPerObservation;
  input.features = counts.ok() ? counts->features : input.input_bytes / kLogBytesPerFeature;
  input.poses = counts.ok() ? counts->poses : input.input_bytes / kLogBytesPerPose;
  input.feature_id_end = counts.ok() ? counts->feature_id_end : -1;
  return input;
}

StatusOr<IngestBudget> BudgetIngest(int64_t limit_bytes, const IngestInput& input,
                                    int64_t chunk_observations) {
  IngestBudget budget;
  const int64_t poses = input.poses * kIngestBytesPerPose;
  const int64_t fixed = input.FixedBytes();
  // Before the buffer: pass 1 of a streamed log, the whole problem otherwise.
  const int64_t read = input.streamed
                           ? fixed + poses + input.Pass1FeatureBytes()
                           : fixed + input.input_bytes * kReadWholeBytesPerInputByte;
  const int64_t pass2 = input.streamed
                            ? fixed + poses + input.features * kIngestPass2BytesPerFeature
                            : read;
  budget.need_bytes =
      std::max(read, pass2 + chunk_observations * kIngestBytesPerBufferedObservation);
  if (limit_bytes <= 0) {
    // No limit: a third of 1 GiB in 72-byte records, as the ingest always had.
    budget.buffer_observations = std::max(
        chunk_observations, (int64_t{1} << 30) / (3 * static_cast<int64_t>(sizeof(core::Observation))));
    return budget;
  }
  if (limit_bytes < budget.need_bytes) {
    return Status::InvalidArgument(
        BelowNeed("--memory-limit", limit_bytes, "estimated need", budget.need_bytes) +
        ". Estimated from the input's " +
        std::to_string(input.input_bytes) + " bytes" +
        (input.streamed ? std::string(input.counted ? " (" : " (~") +
                              std::to_string(input.poses) + (input.counted ? " poses, " : " poses, ~") +
                              std::to_string(input.features) +
                              (input.counted ? " features, counted by the log's trailer): "
                                             : " features): ") +
                              FormatBytes(fixed) + " fixed + " + FormatBytes(poses) +
                              " poses + " +
                              FormatBytes(input.Pass1FeatureBytes()) + " features" +
                              (input.counted && input.feature_id_end >= 0
                                   ? " and ids (" + std::to_string(input.feature_id_end) +
                                         " ids in the table)"
                                   : std::string()) +
                              " in pass 1"
                        : ", read whole: " + FormatBytes(read)) +
        ", and a buffer of one chunk (" + std::to_string(chunk_observations) +
        " observations, " + FormatBytes(chunk_observations * kIngestBytesPerBufferedObservation) +
        ") in pass 2");
  }
  int64_t buffer = (limit_bytes - pass2) / kIngestBytesPerBufferedObservation;
  if (input.observations > 0) buffer = std::min(buffer, input.observations);
  budget.buffer_observations = std::max(buffer, chunk_observations);
  return budget;
}

StatusOr<SolveBudget> BudgetSolve(int64_t limit_bytes, const SolveSize& size,
                                  int default_in_flight) {
  SolveBudget budget;
  const auto rest_for = [&size](bool streaming) {
    return kSolveBaseBytes + size.poses * kPoseSystemBytesPerPose +
           (streaming ? size.features * kBytesPerFeatureStreaming
                      : size.features * kBytesPerFeature +
                            size.observations * kBytesPerObservationInMemory);
  };
  const int64_t rest = rest_for(size.streaming);
  const int64_t chunk = std::max<int64_t>(size.chunk_observations, 1) * kBytesPerObservationInFlight;
  const int64_t read =
      size.problem_bytes <= 0
          ? 0
          : kSolveBaseBytes + std::min(kReaderBlockBytes, size.problem_bytes * 3 / 2) +
                size.features * kReadBytesPerFeature + size.poses * kReadBytesPerPose;
  budget.need_bytes = std::max(read, rest + chunk);
  if (limit_bytes <= 0) {
    budget.chunks_in_flight = default_in_flight;
    return budget;
  }
  if (limit_bytes < budget.need_bytes) {
    std::string message =
        BelowNeed("--memory-limit", limit_bytes, "estimated need", budget.need_bytes) +
        ". Parts: " + FormatBytes(kSolveBaseBytes) +
        " fixed + " + FormatBytes(size.poses * kPoseSystemBytesPerPose) + " for " +
        std::to_string(size.poses) + " poses + " +
        FormatBytes(rest - kSolveBaseBytes - size.poses * kPoseSystemBytesPerPose) + " for " +
        std::to_string(size.features) + " features" +
        (size.streaming ? std::string()
                        : " and " + std::to_string(size.observations) + " observations in memory") +
        " + one chunk of " + std::to_string(size.chunk_observations) + " observations (" +
        FormatBytes(chunk) + ")";
    if (read > rest + chunk)
      message += "; reading the problem file (" + std::to_string(size.problem_bytes) +
                 " bytes) needs " + FormatBytes(read);
    if (!size.streaming) {
      const int64_t streaming_need = std::max(read, rest_for(true) + chunk);
      if (streaming_need <= limit_bytes)
        message += "; streaming mode (--streaming-poses 0) needs " + FormatBytes(streaming_need) +
                   " and fits";
      else
        message += "; streaming mode (--streaming-poses 0) would need " +
                   FormatBytes(streaming_need);
    }
    return Status::InvalidArgument(message);
  }
  // The read is over before the passes: they share the limit with nothing.
  budget.chunks_in_flight =
      static_cast<int>(std::clamp<int64_t>((limit_bytes - rest) / chunk, 1, default_in_flight));
  budget.factor_bytes = limit_bytes - rest - budget.chunks_in_flight * chunk;
  // The start's sample is freed before the solve's passes.
  if (size.streaming)
    budget.sample_observations = (limit_bytes - rest - chunk) / kBytesPerObservationInMemory;
  return budget;
}

Status CheckCholmodFactor(int64_t limit_bytes, const SolveSize& size, int default_in_flight,
                          double factor_bytes) {
  const int64_t factor_need =
      static_cast<int64_t>(std::ceil(factor_bytes)) * kCholmodBytesPerFactorByte;
  const auto holds = [&](int64_t limit) {
    const StatusOr<SolveBudget> budget = BudgetSolve(limit, size, default_in_flight);
    return budget.ok() && budget->factor_bytes >= factor_need;
  };
  if (holds(limit_bytes)) return Status::Ok();
  // The factor shares the limit with the chunks in flight, which take
  // whole chunks of what is above the rest: the smallest limit that holds
  // it is the rest + k chunks + the factor for the smallest k whose budget
  // keeps k chunks in flight (at the latest k = default_in_flight).
  const SolveBudget least = BudgetSolve(0, size, default_in_flight).value();
  const int64_t chunk =
      std::max<int64_t>(size.chunk_observations, 1) * kBytesPerObservationInFlight;
  const int64_t rest_and_chunk = BudgetSolve(0, SolveSize{size.poses, size.features,
                                                          size.observations,
                                                          size.chunk_observations,
                                                          size.streaming, 0},
                                             default_in_flight)
                                     .value()
                                     .need_bytes;
  int64_t smallest = 0;
  for (int k = 1; k <= std::max(default_in_flight, 1) && smallest == 0; ++k) {
    const int64_t limit =
        std::max(least.need_bytes, rest_and_chunk + (k - 1) * chunk + factor_need);
    if (holds(limit)) smallest = limit;
  }
  if (smallest == 0) smallest = least.need_bytes + default_in_flight * chunk + factor_need;
  return CholmodRefusal("--memory-limit", limit_bytes, "--solver cholmod", "--solver auto",
                        factor_bytes, factor_need, smallest);
}

Status CholmodRefusal(const std::string& option, int64_t limit_bytes, const std::string& cholmod,
                      const std::string& automatic, double factor_bytes, int64_t factor_need,
                      int64_t smallest) {
  return Status::InvalidArgument(
      option + " " + FormatBytes(limit_bytes) + " does not hold " + cholmod + ": its factor (" +
      FormatBytes(static_cast<int64_t>(factor_bytes)) + " of values from the symbolic "
      "analysis, " + FormatBytes(factor_need) + " with its indices, the copy of S and "
      "workspace) needs a limit of at least " + FormatBytes(smallest) + " (" +
      std::to_string(smallest) + " bytes): the smallest limit that works; or " + automatic +
      ", which takes PCG when the factor does not fit");
}

}  // namespace graphslam::tools
