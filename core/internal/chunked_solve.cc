#include "core/internal/chunked_solve.h"

#include "core/internal/chunked_solve_impl.h"
#include "core/internal/single_process.h"

namespace graphslam::core::internal {

template <class Space>
Status SolveChunked(
    const SolverOptions& options, const BasicChunkSource<typename Space::Observation>& chunks,
    typename Space::Problem* problem, SolverSummary* summary, const CheckpointOf<Space>* resume,
    const std::function<Status(const CheckpointOf<Space>&)>& checkpoint_callback) {
  SingleProcess one_process;
  return SolveChunkedWith<Space>(options, chunks, problem, summary, resume, checkpoint_callback,
                                 &one_process);
}

template Status SolveChunked<Space2d>(const SolverOptions&, const ChunkSource&, Problem2d*,
                                      SolverSummary*, const SolverCheckpoint*,
                                      const std::function<Status(const SolverCheckpoint&)>&);
template Status SolveChunked<Space3d>(const SolverOptions&, const ChunkSource3d&, Problem3d*,
                                      SolverSummary*, const CheckpointOf<Space3d>*,
                                      const std::function<Status(const CheckpointOf<Space3d>&)>&);

}  // namespace graphslam::core::internal
