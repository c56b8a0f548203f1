#include "partition/association/provisional_rescue.h"

#include "partition/association/internal/observation_chi2.h"

namespace graphslam::partition {

int32_t UniqueCompatibleFeature(const std::vector<const core::Observation*>& sightings,
                                const std::vector<core::Pose2>& poses,
                                const std::vector<core::Point2>& features, double gate) {
  int32_t found = -1;
  for (size_t f = 0; f < features.size(); ++f) {
    double chi2 = 0.0;
    for (const core::Observation* o : sightings) {
      chi2 += internal::ObservationChi2(*o, poses[o->pose], features[f]);
      if (!(chi2 <= gate)) break;
    }
    if (!(chi2 <= gate)) continue;
    if (found >= 0) return -1;  // ambiguous: two features fit
    found = static_cast<int32_t>(f);
  }
  return found;
}

}  // namespace graphslam::partition
