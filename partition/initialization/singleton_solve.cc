#include "partition/initialization/singleton_solve.h"

#include <utility>
#include <vector>

#include "core/observation_models.h"

namespace graphslam::partition {

Status SolveWithoutSingletons(const core::SolverOptions& options, const ChunkingOptions& chunking,
                              core::Problem2d* problem, core::SolverSummary* summary,
                              int64_t* singletons, bool release_observations) {
  // The only observation of each feature seen once (-1: none or several).
  std::vector<int64_t> only(problem->features.size(), -1);
  std::vector<int32_t> count(problem->features.size(), 0);
  for (size_t o = 0; o < problem->observations.size(); ++o) {
    const int32_t f = problem->observations[o].feature;
    if (++count[f] == 1) only[f] = static_cast<int64_t>(o);
  }
  // A measurement its model rejects (a range-bearing observation at range 0)
  // does not determine its feature (E is singular): such a feature stays in
  // the solve.
  auto invertible = [&](int64_t o) {
    const core::Observation& obs = problem->observations[o];
    return core::IsValidMeasurement(obs.kind, obs.z);
  };
  std::vector<uint8_t> left_out(problem->features.size(), 0);
  int64_t left_out_count = 0;
  for (size_t f = 0; f < only.size(); ++f) {
    if (count[f] != 1 || !invertible(only[f])) continue;
    left_out[f] = 1;
    ++left_out_count;
  }
  if (singletons != nullptr) *singletons = left_out_count;
  if (left_out_count == 0) {
    if (!release_observations) {
      const InMemoryChunkSource chunks(*problem, chunking);
      return core::SolveGraphSlam(options, chunks, problem, summary);
    }
    const InMemoryChunkSource chunks(std::move(problem->observations), problem->num_features(),
                                     chunking);
    std::vector<core::Observation>().swap(problem->observations);
    return core::SolveGraphSlam(options, chunks, problem, summary);
  }

  // Each singleton's observation, kept for placing it after the solve.
  std::vector<core::Observation> single;
  single.reserve(static_cast<size_t>(left_out_count));
  for (size_t f = 0; f < only.size(); ++f)
    if (left_out[f]) single.push_back(problem->observations[only[f]]);
  // SolveGraphSlam reads observations only through the chunk source: the
  // singletons' features are then unobserved there, excluded and untouched.
  {
    const int32_t n = problem->num_features();
    const InMemoryChunkSource chunks =
        release_observations
            ? InMemoryChunkSource(std::move(problem->observations), n, chunking, left_out)
            : InMemoryChunkSource(problem->observations, n, chunking, left_out);
    if (release_observations) std::vector<core::Observation>().swap(problem->observations);
    GS_RETURN_IF_ERROR(core::SolveGraphSlam(options, chunks, problem, summary));
  }
  for (const core::Observation& o : single)
    problem->features[o.feature] = core::InvertObservation(o.kind, problem->poses[o.pose], o.z);
  return Status::Ok();
}

}  // namespace graphslam::partition
