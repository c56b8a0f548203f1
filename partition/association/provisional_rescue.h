// UniqueCompatibleFeature: the one confirmed feature that the sightings of a
// provisional feature fit at the final estimate of the incremental pass, or
// none (partition/association/incremental_association.h; docs/association.md,
// "Provisional features re-tested against the final map").
//
// A provisional feature is dropped as clutter when no later scan confirms it
// within the provisional window. On Victoria Park most such features are not
// misdetections but first sightings of a tree whose next sighting comes after
// a long loop, when the provisional feature is gone (55 of the 81 dropped
// sightings belong to trees with more sightings; at the known-correspondence
// optimum they fit their tree with chi2 0.001-0.09, their next-best tree with
// 10-10^6). So before a provisional feature is reported as clutter, its
// sightings z_i (from poses x_i) are tested against each confirmed feature m
// in reach, at the solved poses and positions:
//
//   chi2(m) = sum_i e_i^T Omega_i e_i,   e_i = h(x_i, m) - z_i,
//   compatible  <=>  chi2(m) <= s^2 F^{-1}(Phi(z); 2n)   (n sightings)
//
// with s^2 the pass's variance factor. The pose and feature uncertainties are
// left out, which only tightens the gate: a feature mapped from many
// sightings is known far better than one sighting. Only a unique compatible
// feature is taken; a sighting that fits two (or none) stays clutter.
//
// THREAD SAFETY: pure function. ALLOCATION: none.
#pragma once

#include <cstdint>
#include <vector>

#include "core/problem.h"

namespace graphslam::partition {

// The index into `features` of the only one whose chi2 against `sightings`
// (observations of poses[o.pose]) is at most `gate`; -1 if none or several.
int32_t UniqueCompatibleFeature(const std::vector<const core::Observation*>& sightings,
                                const std::vector<core::Pose2>& poses,
                                const std::vector<core::Point2>& features, double gate);

}  // namespace graphslam::partition
