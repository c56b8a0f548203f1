// LocalizeFromFeatures: where a new pose is, from its observations of
// features already placed, before a stage of incremental initialization
// solves it. With dense sensing (hundreds of features per pose, most of them
// seen from the poses before) the features pin a pose far better than weak
// odometry chained from its predecessor: chained over 25 poses at 0.03 rad of
// heading noise each, odometry ends metres off and the stage's solve starts
// outside the basin.
//
// Closed form (2-D rigid alignment, Umeyama 1991 without scale): with l_i the
// feature as observation i places it in the pose's own frame (Table 1
// inverted from the identity pose) and g_i its placed position, the pose
// (R(theta), t) minimizing sum_i |R l_i + t - g_i|^2 is
//   theta = atan2(sum_i l'_i x g'_i, sum_i l'_i . g'_i),  t = g_bar - R l_bar
// with l' = l - l_bar, g' = g - g_bar the centred points (x the 2-D cross
// product).
// Choice and refinement: of `guess` (the odometry-chained pose) and the
// closed-form pose, the one with the lower observation chi2
//   chi2(x) = sum_i e_i(x)^T W_i e_i(x),  e_i = h(x, g_i) - z_i
// is kept and refined by Gauss-Newton on the pose alone (features held),
// each step kept only if it lowers chi2; the result is kept only if its chi2
// per observation is at most max_chi2_per_observation and the features pin it:
// with H = sum_i J_i^T W_i J_i the pose's information from them at the
// result, its marginal standard deviations sqrt((H^-1)_thth) and
// sqrt(lambda_max((H^-1)_xy)) must be at most max_heading_sigma and
// max_position_sigma. Range-bearing observations of features bunched in one
// spot (a dense campus: the few placed features a pose after a feature-free
// stretch shares with its predecessor, 15 features within 0.09 m at 8 m)
// leave the pose free to swing about them, heading and bearings turning
// together, at no cost in chi2: the alignment then picks a heading by noise
// (2 rad off), the features placed from that pose carry the error into a
// rigid block of poses, and the stage settles in a local minimum.
// Only range-bearing and point
// observations take part (a bearing alone places no point), and only when at
// least min_features distinct placed features are seen: a pose that sees a
// few landmarks (Victoria Park, MRCLAM) or none (pose graphs) keeps `guess`.
//
// THREAD SAFETY: pure function. ALLOCATION: O(observations of the pose).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/problem.h"

namespace graphslam::partition {

struct FeatureLocalizationOptions {
  // The fewest placed features a pose must see to be localized from them.
  int min_features = 8;
  // Gauss-Newton steps on the chosen pose.
  int max_iterations = 5;
  // The largest chi2 per observation the localized pose may keep: placed
  // features that disagree among themselves (a place revisited after drift,
  // features first seen from poses not yet solved) give a pose that fits
  // none of them, and the guess is kept then. A pose in the basin fits at
  // about 2-3 per observation (the placed features' own error adds to the
  // measurement's).
  double max_chi2_per_observation = 6.0;
  // The largest marginal standard deviations of the localized pose's heading
  // [rad] and position [m] the features may leave (above: the guess is
  // kept). Features spread over the sensor's field pin a pose to about
  // 0.001 rad; a bunch 0.09 m wide seen from 8 m leaves about 0.5 rad.
  double max_heading_sigma = 0.05;
  double max_position_sigma = 0.5;
  // Only features with placed[f] >= this take part (a caller may rank how
  // far it trusts its placed features).
  uint8_t placed_at_least = 1;
};

struct FeatureLocalization {
  bool localized = false;  // false: too few placed features or no fit, *pose == guess
  bool closed_form_chosen = false;  // the closed-form pose beat `guess`
  int features = 0;                 // placed features used
  double guess_chi2 = 0.0;
  double chi2 = 0.0;  // of the returned pose
  // Marginal standard deviations of the localized pose from the features
  // (infinite when they do not pin it at all).
  double heading_sigma = 0.0;
  double position_sigma = 0.0;
};

// The closed-form rigid alignment above: the pose mapping each local[i] onto
// global[i] best in least squares. At least two points, not all coincident
// (else the identity rotation about the centroids).
core::Pose2 AlignPoints2d(const std::vector<core::Point2>& local,
                          const std::vector<core::Point2>& global);

// Localizes a pose from `observations` (all of the pose's; their poses are
// not read) of the features with placed[f] >= options.placed_at_least at
// features[f], starting from `guess`, as described above.
FeatureLocalization LocalizeFromFeatures(const FeatureLocalizationOptions& options,
                                         std::span<const core::Observation> observations,
                                         const std::vector<core::Point2>& features,
                                         const std::vector<uint8_t>& placed,
                                         const core::Pose2& guess, core::Pose2* pose);

}  // namespace graphslam::partition
