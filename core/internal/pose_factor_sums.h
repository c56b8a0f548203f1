// The definitions of the templates PoseFactorsChi2, LinearizePoseFactors and
// AppendPoseFactorPattern (core/pose_factors.h), written once for both spaces.
// A space's .cc file lists its pose-only factors in a specialization of
// internal::PoseFactorList<Problem> (a PoseFactorTable of PoseFactorEntry
// lines) and instantiates the three functions for
// its Problem: core/pose_factors.cc (planar), core/pose_factors_3d.cc (3-D).
//
// A factor is a PoseFactor<Constraint, k, pose dimension, Model> with
//   bool Model(const Constraint&, const std::vector<Pose>& poses,
//              Residual* e, Jacobian* j_a, Jacobian* j_b)
// giving e (k x 1) and de/dd (k x pose dimension) w.r.t. the body-frame
// increments d of the pose retraction (the Jacobians may be nullptr). A
// constraint with a member `pose` is unary (j_b unused), else it couples
// `from` and `to`. Model returns false when the constraint is degenerate at
// `poses` (or is not this factor's: the binary and the three-pose robot
// sightings share one list) and contributes nothing. A binary factor may also
// provide
//   static double Linearize(const Constraint&, const std::vector<Pose>&,
//                           const RobustKernel&, PoseFactorSink<pose dimension>*)
// adding its blocks (AddBinaryBlocks) from products that use the structure
// of its Jacobians and returning its rho(s); LinearizePoseFactors calls it
// instead of Model and AddBinary. A TernaryPoseFactor's Model takes a third
// Jacobian and couples `from`, `to` and `to_next`.
//
// For each constraint, with IRLS weight W' = rho'(s) W, s = e^T W e
// (core/internal/robust_term.h):
//   H_kl += A_k^T W' A_l,   g_k += A_k^T W' e,   chi2 += rho(s)
// for the unknown (not anchored) poses k, l it touches. The lists are visited
// in the order the specialization gives and chi2 is summed in that order, so
// the sums do not depend on how the code is arranged.
//
// THREAD SAFETY: pure functions of their inputs; outputs are caller-owned.
// ALLOCATION: none beyond the caller's outputs.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/check.h"
#include "core/internal/robust_term.h"
#include "core/pose_factors.h"
#include "core/robust_kernel.h"
#include "core/unknown_layout.h"

namespace graphslam::core {
namespace internal {

// Specialized per problem type: a static
//   template <class Visit> void ForEach(const Problem&, const PoseFactorKernels&, Visit&& visit)
// calling visit(F{}, constraints, kernel) for each factor type F in turn,
// usually by deriving from PoseFactorTable below.
template <class Problem>
struct PoseFactorList;

// One line of a factor list: factor F over the constraints problem.*kConstraints,
// robustified by kernels.*kKernel.
template <class F, auto kConstraints, auto kKernel>
struct PoseFactorEntry {
  template <class Problem, class Visit>
  static void Apply(const Problem& problem, const PoseFactorKernels& kernels, Visit&& visit) {
    visit(F{}, problem.*kConstraints, kernels.*kKernel);
  }
};

// A PoseFactorList's ForEach from its entries, visited in the order given.
template <class... Entries>
struct PoseFactorTable {
  template <class Problem, class Visit>
  static void ForEach(const Problem& problem, const PoseFactorKernels& kernels, Visit&& visit) {
    (Entries::Apply(problem, kernels, visit), ...);
  }
};

template <class C, int kResidual, int kPoseDim, auto Model>
struct PoseFactor {
  using Constraint = C;
  using Residual = Eigen::Matrix<double, kResidual, 1>;
  using Jacobian = Eigen::Matrix<double, kResidual, kPoseDim>;
  static constexpr bool kUnary = requires(const C& c) { c.pose; };
  static constexpr bool kTernary = false;
  static constexpr auto Evaluate = Model;
};

// Model(c, poses, e, j_from, j_to, j_to_next).
template <class C, int kResidual, int kPoseDim, auto Model>
struct TernaryPoseFactor {
  using Constraint = C;
  using Residual = Eigen::Matrix<double, kResidual, 1>;
  using Jacobian = Eigen::Matrix<double, kResidual, kPoseDim>;
  static constexpr bool kUnary = false;
  static constexpr bool kTernary = true;
  static constexpr auto Evaluate = Model;
};

// F's residual at `poses` (no Jacobians); false when it contributes nothing.
template <class F, class Pose>
bool EvaluateResidual(const typename F::Constraint& c, const std::vector<Pose>& poses,
                      typename F::Residual* e) {
  if constexpr (F::kTernary) {
    return F::Evaluate(c, poses, e, nullptr, nullptr, nullptr);
  } else {
    return F::Evaluate(c, poses, e, nullptr, nullptr);
  }
}

// H_ik += block for i <= k (H stores the upper blocks, row-major), or
// H_ki += block^T for i > k; the block must be in the pattern.
template <int kPose>
void AddPoseBlock(BlockSparseMatrix* hessian, int i, int k,
                  const Eigen::Matrix<double, kPose, kPose>& block) {
  using Stored = Eigen::Map<Eigen::Matrix<double, kPose, kPose, Eigen::RowMajor>>;
  GS_CHECK(hessian->block_size() == kPose);
  double* stored = hessian->MutableBlock(std::min(i, k), std::max(i, k));
  GS_CHECK(stored != nullptr);
  if (i <= k) {
    Stored(stored) += block;
  } else {
    Stored(stored) += block.transpose();
  }
}

// The normal-equation blocks of one constraint (kPose = pose dimension).
template <int kPose>
struct PoseFactorSink {
  const UnknownLayout& layout;
  BlockSparseMatrix* hessian;
  Eigen::VectorXd* gradient;
  Eigen::VectorXd* hessian_diagonal;

  template <int kResidual>
  void AddUnary(int32_t pose, const Eigen::Matrix<double, kResidual, kPose>& jacobian,
                const Eigen::Matrix<double, kResidual, kResidual>& information,
                const Eigen::Matrix<double, kResidual, 1>& residual) {
    const int32_t u = layout.unknown_index[pose];
    if (u < 0) return;
    const Eigen::Matrix<double, kPose, kResidual> w = jacobian.transpose() * information;
    const Eigen::Matrix<double, kPose, kPose> h = w * jacobian;
    AddPoseBlock<kPose>(hessian, u, u, h);
    gradient->template segment<kPose>(kPose * u) += w * residual;
    hessian_diagonal->template segment<kPose>(kPose * u) += h.diagonal();
  }

  template <int kResidual>
  void AddBinary(int32_t pose_a, int32_t pose_b,
                 const Eigen::Matrix<double, kResidual, kPose>& jacobian_a,
                 const Eigen::Matrix<double, kResidual, kPose>& jacobian_b,
                 const Eigen::Matrix<double, kResidual, kResidual>& information,
                 const Eigen::Matrix<double, kResidual, 1>& residual) {
    using Block = Eigen::Matrix<double, kPose, kPose>;
    const int32_t ua = layout.unknown_index[pose_a];
    const int32_t ub = layout.unknown_index[pose_b];
    const Eigen::Matrix<double, kPose, kResidual> wa = jacobian_a.transpose() * information;
    const Eigen::Matrix<double, kPose, kResidual> wb = jacobian_b.transpose() * information;
    if (ua >= 0) {
      const Block haa = wa * jacobian_a;
      AddPoseBlock<kPose>(hessian, ua, ua, haa);
      gradient->template segment<kPose>(kPose * ua) += wa * residual;
      hessian_diagonal->template segment<kPose>(kPose * ua) += haa.diagonal();
    }
    if (ub >= 0) {
      const Block hbb = wb * jacobian_b;
      AddPoseBlock<kPose>(hessian, ub, ub, hbb);
      gradient->template segment<kPose>(kPose * ub) += wb * residual;
      hessian_diagonal->template segment<kPose>(kPose * ub) += hbb.diagonal();
    }
    if (ua >= 0 && ub >= 0 && ua != ub) {
      // Store the upper block (row < column).
      if (ua < ub) {
        AddPoseBlock<kPose>(hessian, ua, ub, Block(wa * jacobian_b));
      } else {
        AddPoseBlock<kPose>(hessian, ub, ua, Block(wb * jacobian_a));
      }
    }
  }

  // The same sums from blocks a factor computed itself: h_aa = A_a^T W A_a,
  // h_bb, h_ab = A_a^T W A_b, g_a = A_a^T W e, g_b.
  void AddBinaryBlocks(int32_t pose_a, int32_t pose_b,
                       const Eigen::Matrix<double, kPose, kPose>& h_aa,
                       const Eigen::Matrix<double, kPose, kPose>& h_bb,
                       const Eigen::Matrix<double, kPose, kPose>& h_ab,
                       const Eigen::Matrix<double, kPose, 1>& g_a,
                       const Eigen::Matrix<double, kPose, 1>& g_b) {
    const int32_t ua = layout.unknown_index[pose_a];
    const int32_t ub = layout.unknown_index[pose_b];
    if (ua >= 0) {
      AddPoseBlock<kPose>(hessian, ua, ua, h_aa);
      gradient->template segment<kPose>(kPose * ua) += g_a;
      hessian_diagonal->template segment<kPose>(kPose * ua) += h_aa.diagonal();
    }
    if (ub >= 0) {
      AddPoseBlock<kPose>(hessian, ub, ub, h_bb);
      gradient->template segment<kPose>(kPose * ub) += g_b;
      hessian_diagonal->template segment<kPose>(kPose * ub) += h_bb.diagonal();
    }
    if (ua >= 0 && ub >= 0 && ua != ub) AddPoseBlock<kPose>(hessian, ua, ub, h_ab);
  }

  // The blocks of a factor on the distinct poses `pose[0..2]`: for each pair
  // of unknown poses k <= l, H_kl += A_k^T W A_l.
  template <int kResidual>
  void AddTernary(const int32_t (&pose)[3],
                  const Eigen::Matrix<double, kResidual, kPose>* const (&jacobian)[3],
                  const Eigen::Matrix<double, kResidual, kResidual>& information,
                  const Eigen::Matrix<double, kResidual, 1>& residual) {
    int32_t u[3];
    Eigen::Matrix<double, kPose, kResidual> w[3];
    for (int k = 0; k < 3; ++k) {
      u[k] = layout.unknown_index[pose[k]];
      w[k] = jacobian[k]->transpose() * information;
    }
    for (int k = 0; k < 3; ++k) {
      if (u[k] < 0) continue;
      const Eigen::Matrix<double, kPose, kPose> hkk = w[k] * *jacobian[k];
      AddPoseBlock<kPose>(hessian, u[k], u[k], hkk);
      gradient->template segment<kPose>(kPose * u[k]) += w[k] * residual;
      hessian_diagonal->template segment<kPose>(kPose * u[k]) += hkk.diagonal();
      for (int l = 0; l < 3; ++l) {
        if (u[l] <= u[k]) continue;  // each pair once, as the upper block
        AddPoseBlock<kPose>(hessian, u[k], u[l],
                            Eigen::Matrix<double, kPose, kPose>(w[k] * *jacobian[l]));
      }
    }
  }
};

}  // namespace internal

template <class Problem>
double PoseFactorsChi2(const Problem& problem, const std::vector<typename Problem::Pose>& poses,
                       const PoseFactorKernels& kernels) {
  double chi2 = 0.0;
  internal::PoseFactorList<Problem>::ForEach(
      problem, kernels, [&](auto factor, const auto& constraints, const RobustKernel& kernel) {
        using F = decltype(factor);
        typename F::Residual e;
        for (const typename F::Constraint& c : constraints) {
          if (!internal::EvaluateResidual<F>(c, poses, &e)) continue;
          chi2 += internal::RobustTerm<F::Residual::RowsAtCompileTime>(kernel, e, c.information, nullptr);
        }
      });
  return chi2;
}

template <class Problem>
double LinearizePoseFactors(const Problem& problem,
                            const std::vector<typename Problem::Pose>& poses,
                            const UnknownLayout& layout, BlockSparseMatrix* hessian,
                            Eigen::VectorXd* gradient, Eigen::VectorXd* hessian_diagonal,
                            const PoseFactorKernels& kernels) {
  double chi2 = 0.0;
  internal::PoseFactorList<Problem>::ForEach(
      problem, kernels, [&](auto factor, const auto& constraints, const RobustKernel& kernel) {
        using F = decltype(factor);
        constexpr int kResidual = F::Residual::RowsAtCompileTime;
        internal::PoseFactorSink<F::Jacobian::ColsAtCompileTime> sink{layout, hessian, gradient,
                                                             hessian_diagonal};
        if constexpr (requires { F::Linearize; }) {
          for (const typename F::Constraint& c : constraints)
            chi2 += F::Linearize(c, poses, kernel, &sink);
          return;
        }
        typename F::Residual e;
        typename F::Jacobian ja, jb, jc;
        Eigen::Matrix<double, kResidual, kResidual> w;
        for (const typename F::Constraint& c : constraints) {
          if constexpr (F::kTernary) {
            if (!F::Evaluate(c, poses, &e, &ja, &jb, &jc)) continue;
            chi2 += internal::RobustTerm<kResidual>(kernel, e, c.information, &w);
            sink.AddTernary({c.from, c.to, c.to_next}, {&ja, &jb, &jc}, w, e);
            continue;
          } else {
            if (!F::Evaluate(c, poses, &e, &ja, &jb)) continue;
          }
          chi2 += internal::RobustTerm<kResidual>(kernel, e, c.information, &w);
          if constexpr (F::kUnary) {
            sink.AddUnary(c.pose, ja, w, e);
          } else {
            sink.AddBinary(c.from, c.to, ja, jb, w, e);
          }
        }
      });
  return chi2;
}

template <class Problem>
void AppendPoseFactorPattern(const Problem& problem, const UnknownLayout& layout,
                             std::vector<std::pair<int, int>>* pairs) {
  internal::PoseFactorList<Problem>::ForEach(
      problem, PoseFactorKernels(), [&](auto factor, const auto& constraints, const RobustKernel&) {
        using F = decltype(factor);
        if constexpr (F::kTernary) {
          for (const typename F::Constraint& c : constraints) {
            if (c.to_next < 0) continue;  // the binary factor's
            const int32_t u[3] = {layout.unknown_index[c.from], layout.unknown_index[c.to],
                                  layout.unknown_index[c.to_next]};
            for (int k = 0; k < 3; ++k)
              for (int l = k + 1; l < 3; ++l)
                if (u[k] >= 0 && u[l] >= 0)
                  pairs->emplace_back(std::min(u[k], u[l]), std::max(u[k], u[l]));
          }
        } else if constexpr (!F::kUnary) {
          for (const typename F::Constraint& c : constraints) {
            const int32_t ua = layout.unknown_index[c.from], ub = layout.unknown_index[c.to];
            if (ua >= 0 && ub >= 0) pairs->emplace_back(std::min(ua, ub), std::max(ua, ub));
          }
        }
      });
}

}  // namespace graphslam::core

// The explicit instantiations of the three templates for one problem type.
#define GS_INSTANTIATE_POSE_FACTORS(Problem)                                                     \
  template double PoseFactorsChi2(const Problem&, const std::vector<Problem::Pose>&,             \
                                  const PoseFactorKernels&);                                     \
  template double LinearizePoseFactors(const Problem&, const std::vector<Problem::Pose>&,        \
                                       const UnknownLayout&, BlockSparseMatrix*,                 \
                                       Eigen::VectorXd*, Eigen::VectorXd*,                       \
                                       const PoseFactorKernels&);                                \
  template void AppendPoseFactorPattern(const Problem&, const UnknownLayout&,                    \
                                        std::vector<std::pair<int, int>>*)
