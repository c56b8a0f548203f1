// The "association" section of the solve report (graphslam solve --associate):
// rounds (candidates, accepted, merges, undone, chi2, seconds per phase), the
// counts, and a bounded list of merges with their correspondence probabilities
// (Table 9) and squared Mahalanobis distances, highest probability first;
// undone merges are listed with the round that undid them.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>

#include "partition/association/association_driver.h"

namespace graphslam::tools {

nlohmann::json BuildAssociationReport(const partition::AssociationOptions& options,
                                      const partition::AssociationSummary& summary,
                                      size_t max_listed_merges);

}  // namespace graphslam::tools
