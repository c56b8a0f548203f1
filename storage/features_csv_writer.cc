#include "storage/features_csv_writer.h"

#include "storage/atomic_file.h"
#include "storage/internal/problem_validation.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {

Status WriteFeaturesCsv(const core::Problem2d& problem, const std::string& path,
                        const std::vector<uint8_t>* excluded, Env* env) {
  const std::string context = "writing " + path;
  GS_RETURN_IF_ERROR(internal::ValidateProblemForWriting(problem, /*shared_id_space=*/false)
                         .WithContext(context));
  if (excluded != nullptr && excluded->size() != problem.features.size()) {
    return Status::InvalidArgument(context + ": excluded has " +
                                   std::to_string(excluded->size()) + " entries; expected " +
                                   std::to_string(problem.features.size()) + " (one per feature)");
  }
  std::vector<int64_t> counts(problem.features.size(), 0);
  for (const auto& observation : problem.observations) ++counts[observation.feature];
  if (env == nullptr) env = Env::Default();
  return WriteFileAtomically(env, path, [&](WritableFile* file) -> Status {
    using internal::FormatDouble;
    GS_RETURN_IF_ERROR(file->Append("id,x,y,observations,excluded\n"));
    std::string line;
    for (int32_t i = 0; i < problem.num_features(); ++i) {
      line.clear();
      internal::AppendField(&line, problem.feature_ids[i]);
      line.push_back(',');
      line.append(FormatDouble(problem.features[i].x()));
      line.push_back(',');
      line.append(FormatDouble(problem.features[i].y()));
      line.push_back(',');
      line.append(std::to_string(counts[i]));
      line.append((excluded != nullptr && (*excluded)[i]) ? ",1\n" : ",0\n");
      GS_RETURN_IF_ERROR(file->Append(line));
    }
    return Status::Ok();
  });
}

}  // namespace graphslam::storage
