#include "storage/features_csv_writer.h"

#include "storage/atomic_file.h"
#include "storage/internal/problem_validation.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

// The header line: id, the point's coordinates, observations, excluded.
template <class Problem>
std::string HeaderLine() {
  constexpr int kDim = Problem::Point::RowsAtCompileTime;
  static_assert(kDim == 2 || kDim == 3);
  return kDim == 2 ? "id,x,y,observations,excluded\n" : "id,x,y,z,observations,excluded\n";
}

// Observations per feature; InvalidArgument for an index out of range.
template <class Problem>
StatusOr<std::vector<int64_t>> ObservationCounts(const Problem& problem) {
  std::vector<int64_t> counts(problem.features.size(), 0);
  for (size_t k = 0; k < problem.observations.size(); ++k) {
    const int32_t feature = problem.observations[k].feature;
    if (feature < 0 || feature >= problem.num_features()) {
      return Status::InvalidArgument("observations[" + std::to_string(k) + "].feature is " +
                                     std::to_string(feature) + "; expected an index in [0, " +
                                     std::to_string(problem.num_features()) + ") (num_features)");
    }
    ++counts[feature];
  }
  return counts;
}

template <class Problem>
Status WriteFeatureRows(const Problem& problem, const std::string& path,
                        const std::vector<uint8_t>* excluded, Env* env) {
  const std::string context = "writing " + path;
  if (excluded != nullptr && excluded->size() != problem.features.size()) {
    return Status::InvalidArgument(context + ": excluded has " +
                                   std::to_string(excluded->size()) + " entries; expected " +
                                   std::to_string(problem.features.size()) + " (one per feature)");
  }
  StatusOr<std::vector<int64_t>> counts_or = ObservationCounts(problem);
  if (!counts_or.ok()) return counts_or.status().WithContext(context);
  const std::vector<int64_t>& counts = *counts_or;
  if (env == nullptr) env = Env::Default();
  return WriteFileAtomically(env, path, [&](WritableFile* file) -> Status {
    using internal::FormatDouble;
    GS_RETURN_IF_ERROR(file->Append(HeaderLine<Problem>()));
    std::string line;
    for (int32_t i = 0; i < problem.num_features(); ++i) {
      line.clear();
      internal::AppendField(&line, problem.feature_ids[i]);
      for (int k = 0; k < Problem::Point::RowsAtCompileTime; ++k) {
        line.push_back(',');
        line.append(FormatDouble(problem.features[i][k]));
      }
      line.push_back(',');
      line.append(std::to_string(counts[i]));
      line.append((excluded != nullptr && (*excluded)[i]) ? ",1\n" : ",0\n");
      GS_RETURN_IF_ERROR(file->Append(line));
    }
    return Status::Ok();
  });
}

}  // namespace

Status WriteFeaturesCsv(const core::Problem2d& problem, const std::string& path,
                        const std::vector<uint8_t>* excluded, Env* env) {
  GS_RETURN_IF_ERROR(internal::ValidateProblemForWriting(problem, /*shared_id_space=*/false)
                         .WithContext("writing " + path));
  return WriteFeatureRows(problem, path, excluded, env);
}

Status WriteFeaturesCsv(const core::Problem3d& problem, const std::string& path,
                        const std::vector<uint8_t>* excluded, Env* env) {
  return WriteFeatureRows(problem, path, excluded, env);
}

}  // namespace graphslam::storage
