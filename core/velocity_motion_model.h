// The velocity motion model of Thrun & Montemerlo (paper eq. 4, Table 2 l.4-6).
//
// A control u = (v, omega) held for dt moves the robot from x_{t-1} = (x, y, th):
//
//   omega != 0:  x_t = x_{t-1} + ( -v/w sin th + v/w sin(th + w dt),
//                                   v/w cos th - v/w cos(th + w dt),
//                                   w dt )
//   omega -> 0:  x_t = x_{t-1} + ( v dt cos th, v dt sin th, 0 )   (the limit)
//
// G_t = dg/dx_{t-1} = [1 0 -v/w cos th + v/w cos(th + w dt)]
//                     [0 1 -v/w sin th + v/w sin(th + w dt)]
//                     [0 0 1                               ]
// (Table 2 l.6 has the wrong sign in the third column; this is the corrected one,
// docs/design.md errata.) Near omega = 0 the series expansion is used so that
// both g and G are smooth through omega = 0.
//
// The constraint residual is e = wrap(x_t - g(u, x_{t-1})) with
// de/dx_{t-1} = -G_t and de/dx_t = I; its information is R_t^{-1}.
//
// Noise: the control noise of Probabilistic Robotics (Thrun, Burgard, Fox 2005,
// Table 5.3) with a final-rotation term gamma, M = diag(a1 v^2 + a2 w^2,
// a3 v^2 + a4 w^2, a5 v^2 + a6 w^2) in (v, w, gamma), mapped to state space:
//   R_t = V M V^T + diag(min_sigma_xy^2, min_sigma_xy^2, min_sigma_theta^2),
// V = d g / d(v, w, gamma); the floor is added so R stays positive definite
// when the robot stands still.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/se2.h"

namespace graphslam::core {

struct VelocityControl {
  double v = 0.0;      // translational velocity [m/s]
  double omega = 0.0;  // rotational velocity [rad/s]
  double dt = 0.0;     // duration [s]
};

struct VelocityNoise {
  // alpha[0..5] = a1..a6 of Probabilistic Robotics Table 5.3.
  double alpha[6] = {0.1, 0.01, 0.01, 0.1, 0.01, 0.1};
  // Minimum standard deviation per step for x, y [m] and theta [rad].
  double min_sigma_xy = 1e-3;
  double min_sigma_theta = 1e-3;
};

// g(u, x_{t-1}); theta of the result is wrapped to (-pi, pi].
Pose2 PredictVelocityMotion(const Pose2& previous, const VelocityControl& control);

// G_t = dg/dx_{t-1}.
Eigen::Matrix3d VelocityMotionJacobian(const Pose2& previous, const VelocityControl& control);

// V = dg/d(v, omega, gamma), gamma being the final rotation of Probabilistic
// Robotics Table 5.3 (theta_t = theta + omega dt + gamma dt):
//   V = [ dt R(th) (S, C)   v dt^2 R(th) (S', C')   0  ]
//       [ 0                 dt                      dt ]
// with a = omega dt, S = sin(a)/a, C = (1 - cos a)/a (series near a = 0).
Eigen::Matrix3d VelocityControlJacobian(const Pose2& previous, const VelocityControl& control);

// The exact inverse of g: the pose x_{t-1} with g(u, x_{t-1}) = current
// (theta_{t-1} = theta_t - omega dt, then the translation is undone).
Pose2 InverseVelocityMotion(const Pose2& current, const VelocityControl& control);

// e = wrap(current - g(u, previous)); Jacobian pointers may be null.
void EvaluateVelocityMotion(const Pose2& previous, const Pose2& current,
                            const VelocityControl& control, Eigen::Vector3d* residual,
                            Eigen::Matrix3d* jacobian_previous,
                            Eigen::Matrix3d* jacobian_current);

// R_t = V M V^T (+ floor), the state-space covariance of one motion step.
Eigen::Matrix3d VelocityMotionCovariance(const Pose2& previous, const VelocityControl& control,
                                         const VelocityNoise& noise);

}  // namespace graphslam::core
