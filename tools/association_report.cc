#include "tools/association_report.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace graphslam::tools {

nlohmann::json BuildAssociationReport(const partition::AssociationOptions& options,
                                      const partition::AssociationSummary& summary,
                                      size_t max_listed_merges) {
  nlohmann::json out;
  out["chi"] = options.chi;
  out["max_mahalanobis_squared"] = options.max_mahalanobis_squared;
  out["search_radius"] = options.search_radius;
  out["initial_features"] = summary.initial_features;
  out["final_features"] = summary.final_features;
  out["merges"] = summary.merges;
  out["undone"] = summary.undone;
  out["converged"] = summary.converged;
  out["seconds"] = summary.seconds;
  const partition::IncrementalAssociationSummary& inc = summary.incremental;
  out["incremental"] = {{"ran", inc.ran},
                        {"stage_poses", options.incremental.stage_poses},
                        {"stage_observations", options.incremental.stage_observations},
                        {"search_radius", options.incremental.search_radius},
                        {"gate_z", options.incremental.joint.z},
                        {"confirm_observations", options.incremental.confirm_observations},
                        {"provisional_poses", options.incremental.provisional_poses},
                        {"provisional_observations",
                         options.incremental.provisional_observations},
                        {"stages", inc.stages},
                        {"scans", inc.scans},
                        {"paired", inc.paired},
                        {"features", inc.features},
                        {"provisional_dropped", inc.provisional_dropped},
                        {"clutter_observations", inc.clutter_observations},
                        {"rescue_provisional", options.incremental.rescue_provisional},
                        {"provisional_rescued", inc.provisional_rescued},
                        {"exhausted_scans", inc.exhausted_scans},
                        {"close_loops", options.incremental.close_loops},
                        {"loop_closures", inc.loop_closures},
                        {"loop_pairs", inc.loop_pairs},
                        {"close_after_gaps", options.incremental.close_after_gaps},
                        {"gap_closures", inc.gap_closures},
                        {"gap_pairs", inc.gap_pairs},
                        {"windowed_stages", inc.windowed_stages},
                        {"largest_window_poses", inc.largest_window_poses},
                        {"chi2", inc.chi2},
                        {"solve_seconds", inc.solve_seconds},
                        {"covariance_seconds", inc.covariance_seconds},
                        {"assignment_seconds", inc.assignment_seconds},
                        {"seconds", inc.seconds}};
  nlohmann::json rounds = nlohmann::json::array();
  for (const auto& r : summary.rounds) {
    rounds.push_back({{"round", r.round},
                      {"features", r.features},
                      {"candidates", r.candidates},
                      {"accepted", r.accepted},
                      {"merges", r.merges},
                      {"undone", r.undone},
                      {"chi2", r.chi2},
                      {"solve_seconds", r.solve_seconds},
                      {"marginal_seconds", r.marginal_seconds},
                      {"association_seconds", r.association_seconds}});
  }
  out["rounds"] = rounds;
  std::vector<const partition::MergeRecord*> order;
  for (const auto& record : summary.merge_log) order.push_back(&record);
  std::stable_sort(order.begin(), order.end(), [](const auto* a, const auto* b) {
    const double pa = std::isnan(a->probability) ? -1.0 : a->probability;
    const double pb = std::isnan(b->probability) ? -1.0 : b->probability;
    return pa > pb;
  });
  nlohmann::json listed = nlohmann::json::array();
  for (size_t i = 0; i < order.size() && i < max_listed_merges; ++i) {
    const auto& m = *order[i];
    nlohmann::json item = {{"round", m.round},
                           {"input_feature_a", m.feature_a},
                           {"input_feature_b", m.feature_b},
                           {"size_a", m.origins_a.size()},
                           {"size_b", m.origins_b.size()},
                           {"forced", m.forced},
                           {"undone", m.undone}};
    if (!std::isnan(m.probability)) {
      item["probability"] = m.probability;
      item["mahalanobis_squared"] = m.mahalanobis_squared;
    }
    if (m.undone) item["undone_round"] = m.undone_round;
    listed.push_back(item);
  }
  out["merge_list"] = listed;
  out["merge_list_truncated"] = order.size() > max_listed_merges;
  return out;
}

}  // namespace graphslam::tools
