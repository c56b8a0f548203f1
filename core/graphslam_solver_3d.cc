#include "core/graphslam_solver_3d.h"

#include "core/internal/chunked_solve.h"
#include "core/point_3d_observation_model.h"
#include "core/pose_factors.h"

namespace graphslam::core {

double Chi2Of3d(const Problem3d& problem, const std::vector<Pose3>& poses,
                const std::vector<Point3>& features) {
  return Chi2Of3d(problem, poses, features, RobustKernel());
}

double Chi2Of3d(const Problem3d& problem, const std::vector<Pose3>& poses,
                const std::vector<Point3>& features, const RobustKernel& kernel,
                const PoseFactorKernels& pose_kernels) {
  double chi2 = PoseFactorsChi2(problem, poses, pose_kernels);
  for (const Point3Observation& o : problem.observations) {
    Eigen::Vector3d e;
    EvaluatePoint3Observation(poses[o.pose], features[o.feature], o.z, &e, nullptr, nullptr);
    chi2 += kernel.Cost(e.dot(o.information * e));
  }
  return chi2;
}

Status SolveGraphSlam3d(const SolverOptions& options, const ChunkSource3d& chunks,
                        Problem3d* problem, SolverSummary* summary,
                        const Checkpointing3d& checkpointing) {
  return internal::SolveChunked<Space3d>(options, chunks, problem, summary,
                                         checkpointing.resume_from, checkpointing.callback);
}

}  // namespace graphslam::core
