#include "core/anderson_acceleration.h"

#include <Eigen/QR>

namespace graphslam::core {

void AndersonAcceleration::Observe(const Eigen::VectorXd& f) {
  // The pair the last Record completed: (x_k - x_{k-1}, f_k - f_{k-1}).
  if (has_recorded_ && recorded_f_.size() == f.size()) {
    dx_.push_back(recorded_taken_);
    df_.push_back(f - recorded_f_);
    if (static_cast<int>(dx_.size()) > depth_) {
      dx_.pop_front();
      df_.pop_front();
    }
  }
  has_recorded_ = false;
  last_f_ = f;
  has_last_f_ = true;
}

bool AndersonAcceleration::Extrapolate(const Eigen::VectorXd& f, Eigen::VectorXd* accelerated) {
  Observe(f);
  *accelerated = f;
  const int m = static_cast<int>(df_.size());
  if (m == 0) return false;
  Eigen::MatrixXd df(f.size(), m);
  for (int i = 0; i < m; ++i) df.col(i) = df_[static_cast<size_t>(i)];
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(df);
  if (qr.rank() < m) return false;
  const Eigen::VectorXd gamma = qr.solve(f);
  for (int i = 0; i < m; ++i)
    *accelerated -= gamma(i) * (dx_[static_cast<size_t>(i)] + df_[static_cast<size_t>(i)]);
  return accelerated->allFinite();
}

void AndersonAcceleration::Record(const Eigen::VectorXd& taken) {
  if (!has_last_f_) return;
  recorded_f_ = last_f_;
  recorded_taken_ = taken;
  has_recorded_ = true;
  has_last_f_ = false;
}

void AndersonAcceleration::Reset() {
  dx_.clear();
  df_.clear();
  has_last_f_ = false;
  has_recorded_ = false;
}

}  // namespace graphslam::core
