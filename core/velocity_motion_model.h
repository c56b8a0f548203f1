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
// Per step or per unit time (VelocityNoise::noise_time_constant = tau):
//   tau = 0 (per step, the book's model): M and the floor as above, whatever
//     dt. V scales with dt, so one step's covariance is ~ dt^2 M and N = T/dt
//     steps over a time T accumulate ~ T dt M: the same motion logged at a
//     higher rate is modelled as more certain, and the floor, which is per
//     step, accumulates ~ (T/dt) floor^2, the other way.
//   tau > 0 (rate independent): M is a spectral density, the variance of the
//     control noise averaged over tau seconds. Held constant over a step of
//     dt, its variance is then M tau/dt, and the floor a variance per tau:
//       R_t = (tau/dt) V M V^T + (dt/tau) diag(min_sigma_xy^2, min_sigma_xy^2,
//                                              min_sigma_theta^2).
//     V = dt V' with V' finite as dt -> 0, so R_t = dt (tau V' M V'^T +
//     floor/tau) ~ Q dt: the covariance accumulated over T (Sigma_{k+1} =
//     G Sigma_k G^T + R_k) tends to the continuous-time one as dt -> 0 and no
//     longer depends on the rate; at dt = tau the step is the per-step
//     model's. A step of dt < 1e-3 tau (repeated stamps) gets the floor of
//     dt = 1e-3 tau so that R stays positive definite.
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
  // Minimum standard deviation per step (per noise_time_constant seconds
  // when that is > 0) for x, y [m] and theta [rad].
  double min_sigma_xy = 1e-3;
  double min_sigma_theta = 1e-3;
  // tau [s]: 0 puts M and the floor on every step (the book's model); > 0
  // makes them densities, so the accumulated covariance does not depend on
  // the step rate and a step of dt = tau gets exactly the per-step values.
  double noise_time_constant = 0.0;
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

// R_t = V M V^T (+ floor), the state-space covariance of one motion step,
// scaled per noise.noise_time_constant (above).
Eigen::Matrix3d VelocityMotionCovariance(const Pose2& previous, const VelocityControl& control,
                                         const VelocityNoise& noise);

}  // namespace graphslam::core
