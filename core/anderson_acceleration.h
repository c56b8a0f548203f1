// AndersonAcceleration: Anderson mixing (Anderson 1965; Walker & Ni 2011) of
// a fixed-point iteration x_{k+1} = x_k + f(x_k), here Gauss-Newton's, whose
// f is the step solved at x_k. Where Gauss-Newton converges only linearly
// (a pose graph whose residuals bend strongly along a soft mode: torus3D's
// steps keep one direction and shrink by ~6 % an iteration), a few past steps
// tell where the iteration is heading.
//
// With the last m accepted iterations' differences
//   dX_i = x_{i+1} - x_i  (the steps taken),  dF_i = f_{i+1} - f_i,
// and f_k the step at the current state,
//   gamma = argmin_g |f_k - dF g|_2              (m unknowns, least squares)
//   v     = f_k - (dX + dF) gamma                 (the accelerated step)
// For a linear iteration f(x) = -A (x - x*) this is GMRES's iterate: exact
// after at most (distinct eigenvalues of A) + 1 steps. A caller evaluates
// x_k (+) v and keeps it only if it beats the plain step (the safeguard),
// and forgets the history when the map changes (a rejected step).
//
// The differences are taken between tangent vectors of different states, as
// if they shared one frame (the body-frame increments of a pose barely turn
// between the small steps of the iterations where the acceleration pays).
//
// THREAD SAFETY: none (one per solve). ALLOCATION: 2 depth + 2 vectors of the
// step's size.
#pragma once

#include <deque>

#include <Eigen/Core>

namespace graphslam::core {

class AndersonAcceleration {
 public:
  explicit AndersonAcceleration(int depth) : depth_(depth) {}

  // f = the plain step at the current state (reached by Record's `taken`
  // from the previous one). *accelerated = v; false without any history (the
  // first step after a Reset) or with a rank-deficient history (v = f then).
  bool Extrapolate(const Eigen::VectorXd& f, Eigen::VectorXd* accelerated);

  // Extrapolate's bookkeeping without the extrapolation: the history still
  // gains the pair, for a caller that skips this state's extrapolation.
  void Observe(const Eigen::VectorXd& f);

  // The step was accepted: the state moved by `taken` (f or the accelerated
  // step) from the state whose plain step was the last Extrapolate's f.
  void Record(const Eigen::VectorXd& taken);

  // The iteration map changed (a rejected step, more damping): start over.
  void Reset();

  int history_size() const { return static_cast<int>(dx_.size()); }

 private:
  int depth_;
  std::deque<Eigen::VectorXd> dx_, df_;
  Eigen::VectorXd last_f_;      // f of the last Extrapolate
  Eigen::VectorXd recorded_f_;  // f of the state before the last Record
  Eigen::VectorXd recorded_taken_;
  bool has_last_f_ = false, has_recorded_ = false;
};

}  // namespace graphslam::core
