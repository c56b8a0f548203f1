#include "distributed/checkpoint_exchange.h"

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>

namespace graphslam::distributed {
namespace {

constexpr size_t kMaxPieceBytes = size_t{1} << 30;

template <class T>
void BroadcastVector(MPI_Comm comm, std::vector<T>* values) {
  uint64_t size = values->size();
  BroadcastBytes(comm, &size, sizeof(size));
  values->resize(size);
  BroadcastBytes(comm, values->data(), size * sizeof(T));
}

}  // namespace

void BroadcastBytes(MPI_Comm comm, void* data, size_t bytes) {
  char* const begin = static_cast<char*>(data);
  for (size_t offset = 0; offset < bytes; offset += kMaxPieceBytes) {
    const size_t piece = std::min(kMaxPieceBytes, bytes - offset);
    MPI_Request request;
    MPI_Ibcast(begin + offset, static_cast<int>(piece), MPI_BYTE, 0, comm, &request);
    int done = 0;
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    while (!done) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    }
  }
}

bool BroadcastCheckpoint(MPI_Comm comm, const core::SolverCheckpoint* root,
                         core::SolverCheckpoint* local) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  uint8_t present = root != nullptr ? 1 : 0;
  BroadcastBytes(comm, &present, 1);
  if (!present) return false;
  if (rank == 0) {
    local->iterations = root->iterations;
    local->trust_region_radius = root->trust_region_radius;
    local->decrease_factor = root->decrease_factor;
    local->initial_chi2 = root->initial_chi2;
    local->chi2 = root->chi2;
    local->converged = root->converged;
    local->termination = root->termination;
    local->poses = root->poses;
    local->excluded = root->excluded;
    local->kept = root->kept;
  }
  int32_t iterations = local->iterations;
  uint8_t converged = local->converged ? 1 : 0;
  double scalars[4] = {local->trust_region_radius, local->decrease_factor, local->initial_chi2,
                       local->chi2};
  BroadcastBytes(comm, &iterations, sizeof(iterations));
  BroadcastBytes(comm, &converged, 1);
  BroadcastBytes(comm, scalars, sizeof(scalars));
  local->iterations = iterations;
  local->converged = converged != 0;
  local->trust_region_radius = scalars[0];
  local->decrease_factor = scalars[1];
  local->initial_chi2 = scalars[2];
  local->chi2 = scalars[3];
  std::vector<char> termination(local->termination.begin(), local->termination.end());
  BroadcastVector(comm, &termination);
  local->termination.assign(termination.begin(), termination.end());
  static_assert(sizeof(core::Pose2) == 3 * sizeof(double));
  BroadcastVector(comm, &local->poses);
  BroadcastVector(comm, &local->excluded);
  BroadcastVector(comm, &local->kept);
  local->features.clear();
  local->pcg = core::PcgSolverState();
  return true;
}

void GatherFeaturesToRoot(MPI_Comm comm, const std::vector<uint8_t>& owned,
                          const std::vector<core::Point2>& features,
                          std::vector<core::Point2>* gathered) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  static_assert(sizeof(core::Point2) == 2 * sizeof(double));
  std::vector<core::Point2> mine(features.size(), core::Point2::Zero());
  for (size_t g = 0; g < features.size(); ++g)
    if (owned[g]) mine[g] = features[g];
  double* const values = mine.empty() ? nullptr : mine.front().data();
  const size_t count = 2 * mine.size();
  constexpr size_t kPiece = kMaxPieceBytes / sizeof(double);
  for (size_t offset = 0; offset < count; offset += kPiece) {
    const int piece = static_cast<int>(std::min(kPiece, count - offset));
    MPI_Reduce(rank == 0 ? MPI_IN_PLACE : values + offset, values + offset, piece, MPI_DOUBLE,
               MPI_SUM, 0, comm);
  }
  gathered->clear();
  if (rank == 0) *gathered = std::move(mine);
}

}  // namespace graphslam::distributed
