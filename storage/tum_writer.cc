#include "storage/tum_writer.h"

#include <cmath>

#include "storage/atomic_file.h"
#include "storage/internal/problem_validation.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {

Status WriteTum(const core::Problem2d& problem, const std::string& path, Env* env) {
  GS_RETURN_IF_ERROR(internal::ValidateProblemForWriting(problem, /*shared_id_space=*/false)
                         .WithContext("writing " + path));
  if (env == nullptr) env = Env::Default();
  return WriteFileAtomically(env, path, [&problem](WritableFile* file) -> Status {
    using internal::AppendField;
    GS_RETURN_IF_ERROR(file->Append("# timestamp x y z qx qy qz qw\n"));
    std::string line;
    for (int32_t i = 0; i < problem.num_poses(); ++i) {
      const double stamp = problem.pose_stamps[i];
      const core::Pose2& pose = problem.poses[i];
      line.clear();
      AppendField(&line, std::isnan(stamp) ? static_cast<double>(i) : stamp);
      AppendField(&line, pose.x());
      AppendField(&line, pose.y());
      AppendField(&line, "0 0 0");
      AppendField(&line, std::sin(0.5 * pose.z()));
      AppendField(&line, std::cos(0.5 * pose.z()));
      line.push_back('\n');
      GS_RETURN_IF_ERROR(file->Append(line));
    }
    return Status::Ok();
  });
}

}  // namespace graphslam::storage
