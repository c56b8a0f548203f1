#include "core/chunk_passes.h"

#include <Eigen/Eigenvalues>
#include <algorithm>

#include "core/feature_linearizer.h"
#include "core/internal/ordered_chunk_pipeline.h"
#include "core/schur_eliminator.h"

namespace graphslam::core {
namespace {

constexpr int kDim = UnknownLayout::kPoseDimension;

bool Excluded(const PassContext& context, int32_t feature) {
  return context.excluded != nullptr && (*context.excluded)[feature] != 0;
}

Eigen::Vector2d DampingDiagonal(const Eigen::MatrixXd& information) {
  return information.diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
}

void Report(const PassContext& context, const char* stage, int64_t done) {
  if (context.progress) context.progress(stage, done, context.chunks->NumChunks());
}

}  // namespace

Status ScreenFeatures(const PassContext& context, const std::vector<Pose2>& poses,
                      const std::vector<Point2>& features, int64_t max_eliminated_observations,
                      ScreeningResult* result) {
  struct Output {
    LinearizedFeature scratch;
    std::vector<int32_t> rejected;
    std::vector<int32_t> kept;
    int64_t observations = 0;
  };
  result->excluded.assign(features.size(), 1);  // unobserved until a chunk says otherwise
  result->kept.assign(features.size(), 0);
  result->kept_count = 0;
  result->excluded_not_positive_definite = 0;
  result->observations = 0;
  std::vector<uint8_t> observed(features.size(), 0);
  Status status = internal::RunOrderedChunkPipeline<Output>(
      *context.chunks, context.max_in_flight,
      [&](const ObservationChunk& chunk, Output* out) {
        out->rejected.clear();
        out->kept.clear();
        out->observations = 0;
        for (int64_t k = 0; k < chunk.num_features(); ++k) {
          const int32_t g = chunk.features[k];
          LinearizeFeature(chunk, k, poses, features[g], *context.layout, RobustKernel(),
                           &out->scratch);
          const Eigen::Matrix2d c = out->scratch.blocks.feature_information;
          Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(c);
          const double max_eigen = eigen.eigenvalues().maxCoeff();
          const double min_eigen = eigen.eigenvalues().minCoeff();
          // Relative test: a rank-deficient C has min/max at round-off level.
          if (!c.allFinite() || !(max_eigen > 0.0) || min_eigen <= 1e-10 * max_eigen) {
            out->rejected.push_back(g);
          } else {
            const int64_t count = chunk.feature_begin[k + 1] - chunk.feature_begin[k];
            out->observations += count;
            if (count > max_eliminated_observations) out->kept.push_back(g);
          }
        }
        return Status::Ok();
      },
      [&](const ObservationChunk& chunk, Output& out) {
        for (int32_t g : chunk.features) {
          observed[g] = 1;
          result->excluded[g] = 0;
        }
        for (int32_t g : out.rejected) result->excluded[g] = 1;
        for (int32_t g : out.kept) result->kept[g] = 1;
        result->kept_count += static_cast<int64_t>(out.kept.size());
        result->excluded_not_positive_definite += static_cast<int64_t>(out.rejected.size());
        result->observations += out.observations;
        Report(context, "screen", chunk.index + 1);
      });
  result->unobserved = std::count(observed.begin(), observed.end(), 0);
  return status;
}

Status CollectReducedPattern(const PassContext& context,
                             std::vector<std::pair<int, int>>* pairs) {
  struct Output {
    std::vector<std::pair<int, int>> pairs;
    std::vector<int> poses;
  };
  return internal::RunOrderedChunkPipeline<Output>(
      *context.chunks, context.max_in_flight,
      [&](const ObservationChunk& chunk, Output* out) {
        out->pairs.clear();
        for (int64_t k = 0; k < chunk.num_features(); ++k) {
          const int32_t g = chunk.features[k];
          if (Excluded(context, g)) continue;
          out->poses.clear();
          for (int64_t o = chunk.feature_begin[k]; o < chunk.feature_begin[k + 1]; ++o) {
            const int32_t u = context.layout->unknown_index[chunk.observations[o].pose];
            if (u >= 0) out->poses.push_back(u);
          }
          std::sort(out->poses.begin(), out->poses.end());
          out->poses.erase(std::unique(out->poses.begin(), out->poses.end()), out->poses.end());
          if (context.layout->IsKept(g)) {
            // Kept features couple only with their observing poses.
            const int fu = context.layout->feature_unknown_index[g];
            out->pairs.emplace_back(fu, fu);
            for (int u : out->poses) out->pairs.emplace_back(u, fu);
            continue;
          }
          for (size_t a = 0; a < out->poses.size(); ++a)
            for (size_t b = a; b < out->poses.size(); ++b)
              out->pairs.emplace_back(out->poses[a], out->poses[b]);
        }
        // Deduplicate per chunk so the merged list stays small.
        std::sort(out->pairs.begin(), out->pairs.end());
        out->pairs.erase(std::unique(out->pairs.begin(), out->pairs.end()), out->pairs.end());
        return Status::Ok();
      },
      [&](const ObservationChunk& chunk, Output& out) {
        pairs->insert(pairs->end(), out.pairs.begin(), out.pairs.end());
        Report(context, "pattern", chunk.index + 1);
      });
}

Status ReducePass(const PassContext& context, const std::vector<Pose2>& poses,
                  const std::vector<Point2>& features, double lambda, ReducedSystem* system) {
  // Blocks added to S as they are (not through elimination): direct pose
  // terms H_pp, and every block of a kept feature, with their gradient.
  struct Direct {
    int row = 0;
    int col = 0;
    Eigen::Matrix3d block;
  };
  struct DirectGradient {
    int row = 0;
    Eigen::Vector3d gradient;
    Eigen::Vector3d diagonal;
  };
  struct Output {
    LinearizedFeature scratch;
    ReducedContribution contribution;
    std::vector<Direct> blocks;
    std::vector<DirectGradient> gradients;
    double chi2 = 0.0;
  };
  return internal::RunOrderedChunkPipeline<Output>(
      *context.chunks, context.max_in_flight,
      [&](const ObservationChunk& chunk, Output* out) -> Status {
        out->contribution.Clear();
        out->blocks.clear();
        out->gradients.clear();
        out->chi2 = 0.0;
        for (int64_t k = 0; k < chunk.num_features(); ++k) {
          const int32_t g = chunk.features[k];
          if (Excluded(context, g)) continue;
          LinearizedFeature& f = out->scratch;
          LinearizeFeature(chunk, k, poses, features[g], *context.layout, context.kernel, &f);
          out->chi2 += f.chi2;
          for (size_t slot = 0; slot < f.blocks.poses.size(); ++slot) {
            const int u = f.blocks.poses[slot];
            out->blocks.push_back({u, u, f.pose_hessian[slot]});
            out->gradients.push_back({u, f.pose_gradient[slot], f.pose_hessian[slot].diagonal()});
          }
          if (context.layout->IsKept(g)) {
            // Padded to the pose block size: third component decoupled.
            const int fu = context.layout->feature_unknown_index[g];
            Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
            c.topLeftCorner<2, 2>() = f.blocks.feature_information;
            c(2, 2) = 1.0;
            Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
            gradient.head<2>() = f.blocks.feature_gradient;
            out->blocks.push_back({fu, fu, c});
            out->gradients.push_back({fu, gradient, c.diagonal()});
            for (size_t slot = 0; slot < f.blocks.poses.size(); ++slot) {
              Eigen::Matrix3d coupling = Eigen::Matrix3d::Zero();
              coupling.leftCols<2>() = f.blocks.pose_feature[slot];
              out->blocks.push_back({f.blocks.poses[slot], fu, coupling});
            }
            continue;
          }
          const Eigen::Vector2d damping = DampingDiagonal(f.blocks.feature_information);
          f.blocks.feature_information.diagonal() += lambda * damping;
          Status status = EliminateFeature(f.blocks, &out->contribution);
          if (!status.ok()) {
            return status.WithContext("chunk " + std::to_string(chunk.index) + ", feature " +
                                      std::to_string(g));
          }
        }
        return Status::Ok();
      },
      [&](const ObservationChunk& chunk, Output& out) {
        AccumulateContribution(out.contribution, &system->matrix, &system->rhs);
        for (const Direct& d : out.blocks) GS_CHECK(system->matrix.AddBlock(d.row, d.col, d.block));
        for (const DirectGradient& d : out.gradients) {
          system->gradient.segment<kDim>(kDim * d.row) += d.gradient;
          system->rhs.segment<kDim>(kDim * d.row) -= d.gradient;
          system->hessian_diagonal.segment<kDim>(kDim * d.row) += d.diagonal;
        }
        system->chi2 += out.chi2;
        Report(context, "reduce", chunk.index + 1);
      });
}

Status RecoverPass(const PassContext& context, const std::vector<Pose2>& poses,
                   const std::vector<Point2>& features, double lambda,
                   const Eigen::VectorXd& step, const std::vector<Pose2>& candidate_poses,
                   std::vector<Point2>* candidate_features, RecoveryResult* result) {
  struct Output {
    LinearizedFeature scratch;
    RecoveryResult sums;
  };
  *result = RecoveryResult();
  candidate_features->resize(features.size());
  return internal::RunOrderedChunkPipeline<Output>(
      *context.chunks, context.max_in_flight,
      [&](const ObservationChunk& chunk, Output* out) -> Status {
        out->sums = RecoveryResult();
        for (int64_t k = 0; k < chunk.num_features(); ++k) {
          const int32_t g = chunk.features[k];
          if (Excluded(context, g)) continue;
          if (context.layout->IsKept(g)) {
            // Solved in the reduced system; its model terms are in the pose part.
            const int fu = context.layout->feature_unknown_index[g];
            (*candidate_features)[g] = features[g] + step.segment<2>(kDim * fu);
            out->sums.candidate_chi2 +=
                FeatureChi2(chunk, k, candidate_poses, (*candidate_features)[g], context.kernel);
            continue;
          }
          LinearizedFeature& f = out->scratch;
          LinearizeFeature(chunk, k, poses, features[g], *context.layout, context.kernel, &f);
          const Eigen::Vector2d damping = DampingDiagonal(f.blocks.feature_information);
          f.blocks.feature_information.diagonal() += lambda * damping;
          const Eigen::Vector2d feature_step = RecoverFeature(f.blocks, step);
          // Each feature lives in exactly one chunk: no two tasks write one slot.
          (*candidate_features)[g] = features[g] + feature_step;
          out->sums.candidate_chi2 +=
              FeatureChi2(chunk, k, candidate_poses, (*candidate_features)[g], context.kernel);
          out->sums.gradient_dot_step += f.blocks.feature_gradient.dot(feature_step);
          out->sums.damped_step_norm += feature_step.dot(damping.cwiseProduct(feature_step));
          out->sums.step_squared_norm += feature_step.squaredNorm();
          out->sums.state_squared_norm += features[g].squaredNorm();
        }
        return Status::Ok();
      },
      [&](const ObservationChunk& chunk, Output& out) {
        result->candidate_chi2 += out.sums.candidate_chi2;
        result->gradient_dot_step += out.sums.gradient_dot_step;
        result->damped_step_norm += out.sums.damped_step_norm;
        result->step_squared_norm += out.sums.step_squared_norm;
        result->state_squared_norm += out.sums.state_squared_norm;
        Report(context, "recover", chunk.index + 1);
      });
}

Status ObservationsChi2(const PassContext& context, const std::vector<Pose2>& poses,
                        const std::vector<Point2>& features, double* chi2) {
  struct Output {
    double chi2 = 0.0;
  };
  *chi2 = 0.0;
  return internal::RunOrderedChunkPipeline<Output>(
      *context.chunks, context.max_in_flight,
      [&](const ObservationChunk& chunk, Output* out) -> Status {
        out->chi2 = 0.0;
        for (int64_t k = 0; k < chunk.num_features(); ++k) {
          if (Excluded(context, chunk.features[k])) continue;
          out->chi2 += FeatureChi2(chunk, k, poses, features[chunk.features[k]], context.kernel);
        }
        return Status::Ok();
      },
      [&](const ObservationChunk&, Output& out) { *chi2 += out.chi2; });
}

}  // namespace graphslam::core
