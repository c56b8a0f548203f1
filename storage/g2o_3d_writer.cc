#include "storage/g2o_3d_writer.h"

#include "storage/atomic_file.h"
#include "storage/internal/g2o_record_writer.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::AppendField;
using internal::G2o3d;

Status Flush(WritableFile* file, std::string* line) {
  line->push_back('\n');
  Status status = file->Append(*line);
  line->clear();
  return status;
}

}  // namespace

Status WriteG2o3d(const core::Problem3d& problem, const std::string& path, Env* env) {
  if (env == nullptr) env = Env::Default();
  return WriteFileAtomically(env, path, [&problem](WritableFile* file) -> Status {
    internal::G2oRecordWriter<G2o3d> out(file, problem);
    // The identity sensor offset every EDGE_SE3_TRACKXYZ names (parameter 0).
    if (!problem.observations.empty())
      GS_RETURN_IF_ERROR(out.Line("PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1"));
    GS_RETURN_IF_ERROR(out.Vertices());
    GS_RETURN_IF_ERROR(out.RelativePoses());
    for (const core::Point3Observation& o : problem.observations)
      GS_RETURN_IF_ERROR(out.PointObservation(o.pose, o.feature, o.z, o.information));
    return out.PositionPriors();
  });
}

Status WriteTum3d(const core::Problem3d& problem, const std::string& path, Env* env) {
  if (env == nullptr) env = Env::Default();
  return WriteFileAtomically(env, path, [&problem](WritableFile* file) -> Status {
    std::string line = "# timestamp x y z qx qy qz qw";
    GS_RETURN_IF_ERROR(Flush(file, &line));
    for (int32_t i = 0; i < problem.num_poses(); ++i) {
      AppendField(&line, static_cast<double>(problem.pose_ids[i]));
      G2o3d::AppendPose(&line, problem.poses[i]);
      GS_RETURN_IF_ERROR(Flush(file, &line));
    }
    return Status::Ok();
  });
}

}  // namespace graphslam::storage
