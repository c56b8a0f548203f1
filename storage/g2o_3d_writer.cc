#include "storage/g2o_3d_writer.h"

#include "storage/atomic_file.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::AppendField;

void AppendPose(std::string* line, const core::Pose3& pose) {
  Eigen::Quaterniond q = pose.q.normalized();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  for (int k = 0; k < 3; ++k) AppendField(line, pose.t[k]);
  AppendField(line, q.x());
  AppendField(line, q.y());
  AppendField(line, q.z());
  AppendField(line, q.w());
}

template <typename Matrix>
void AppendUpper(std::string* line, const Matrix& m) {
  for (int r = 0; r < m.rows(); ++r)
    for (int c = r; c < m.cols(); ++c) AppendField(line, m(r, c));
}

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
    std::string line;
    if (!problem.observations.empty()) {
      line = "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1";
      GS_RETURN_IF_ERROR(Flush(file, &line));
    }
    for (int32_t i = 0; i < problem.num_poses(); ++i) {
      AppendField(&line, "VERTEX_SE3:QUAT");
      AppendField(&line, problem.pose_ids[i]);
      AppendPose(&line, problem.poses[i]);
      GS_RETURN_IF_ERROR(Flush(file, &line));
    }
    for (int32_t i = 0; i < problem.num_features(); ++i) {
      AppendField(&line, "VERTEX_TRACKXYZ");
      AppendField(&line, problem.feature_ids[i]);
      for (int k = 0; k < 3; ++k) AppendField(&line, problem.features[i][k]);
      GS_RETURN_IF_ERROR(Flush(file, &line));
    }
    for (int32_t i = 0; i < problem.num_poses(); ++i) {
      if (!problem.pose_fixed[i]) continue;
      AppendField(&line, "FIX");
      AppendField(&line, problem.pose_ids[i]);
      GS_RETURN_IF_ERROR(Flush(file, &line));
    }
    for (const core::RelativePose3Constraint& c : problem.relative_poses) {
      AppendField(&line, "EDGE_SE3:QUAT");
      AppendField(&line, problem.pose_ids[c.from]);
      AppendField(&line, problem.pose_ids[c.to]);
      AppendPose(&line, c.z);
      AppendUpper(&line, c.information);
      GS_RETURN_IF_ERROR(Flush(file, &line));
    }
    for (const core::Point3Observation& o : problem.observations) {
      AppendField(&line, "EDGE_SE3_TRACKXYZ");
      AppendField(&line, problem.pose_ids[o.pose]);
      AppendField(&line, problem.feature_ids[o.feature]);
      AppendField(&line, int64_t{0});
      for (int k = 0; k < 3; ++k) AppendField(&line, o.z[k]);
      AppendUpper(&line, o.information);
      GS_RETURN_IF_ERROR(Flush(file, &line));
    }
    for (const core::Gps3Constraint& g : problem.gps) {
      AppendField(&line, "EDGE_SE3_XYZPRIOR");
      AppendField(&line, problem.pose_ids[g.pose]);
      for (int k = 0; k < 3; ++k) AppendField(&line, g.z[k]);
      AppendUpper(&line, g.information);
      GS_RETURN_IF_ERROR(Flush(file, &line));
    }
    return Status::Ok();
  });
}

Status WriteTum3d(const core::Problem3d& problem, const std::string& path, Env* env) {
  if (env == nullptr) env = Env::Default();
  return WriteFileAtomically(env, path, [&problem](WritableFile* file) -> Status {
    std::string line = "# timestamp x y z qx qy qz qw";
    GS_RETURN_IF_ERROR(Flush(file, &line));
    for (int32_t i = 0; i < problem.num_poses(); ++i) {
      AppendField(&line, static_cast<double>(problem.pose_ids[i]));
      AppendPose(&line, problem.poses[i]);
      GS_RETURN_IF_ERROR(Flush(file, &line));
    }
    return Status::Ok();
  });
}

}  // namespace graphslam::storage
