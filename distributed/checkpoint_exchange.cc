#include "distributed/checkpoint_exchange.h"

#include <algorithm>
#include <chrono>
#include <cstring>
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
  local->excluded.clear();
  local->kept.clear();
  local->features.clear();
  local->pcg = core::PcgSolverState();
  return true;
}

namespace {

// `count` elements of `element` bytes as one MPI datatype: counts stay those
// of one rank's entries, whatever the element size.
class ElementType {
 public:
  explicit ElementType(size_t element) {
    MPI_Type_contiguous(static_cast<int>(element), MPI_BYTE, &type_);
    MPI_Type_commit(&type_);
  }
  ~ElementType() { MPI_Type_free(&type_); }
  MPI_Datatype get() const { return type_; }

 private:
  MPI_Datatype type_;
};

constexpr int kIndicesTag = 21;
constexpr int kValuesTag = 22;

}  // namespace

FeatureExchange::FeatureExchange(MPI_Comm comm, const FeatureOwnership* ownership)
    : comm_(comm), ownership_(ownership) {
  MPI_Comm_rank(comm, &rank_);
  MPI_Comm_size(comm, &size_);
  const std::vector<int32_t>& mine = ownership->owned_global;
  if (rank_ != 0) {
    const int count = static_cast<int>(mine.size());
    MPI_Send(&count, 1, MPI_INT, 0, kIndicesTag, comm);
    MPI_Send(mine.data(), count, MPI_INT32_T, 0, kIndicesTag, comm);
    return;
  }
  global_of_rank_.resize(size_);
  for (int r = 1; r < size_; ++r) {
    int count = 0;
    MPI_Recv(&count, 1, MPI_INT, r, kIndicesTag, comm, MPI_STATUS_IGNORE);
    global_of_rank_[r].resize(count);
    MPI_Recv(global_of_rank_[r].data(), count, MPI_INT32_T, r, kIndicesTag, comm,
             MPI_STATUS_IGNORE);
  }
}

void FeatureExchange::ScatterBytes(const void* root, void* mine, size_t element) const {
  const ElementType type(element);
  const std::vector<int32_t>& local = ownership_->owned_local;
  char* const out = static_cast<char*>(mine);
  if (rank_ != 0) {
    std::vector<char> buffer(local.size() * element);
    MPI_Recv(buffer.data(), static_cast<int>(local.size()), type.get(), 0, kValuesTag, comm_,
             MPI_STATUS_IGNORE);
    for (size_t i = 0; i < local.size(); ++i)
      std::memcpy(out + static_cast<size_t>(local[i]) * element, buffer.data() + i * element,
                  element);
    return;
  }
  const char* const in = static_cast<const char*>(root);
  const std::vector<int32_t>& global = ownership_->owned_global;
  for (size_t i = 0; i < local.size(); ++i)
    std::memcpy(out + static_cast<size_t>(local[i]) * element,
                in + static_cast<size_t>(global[i]) * element, element);
  std::vector<char> buffer;
  for (int r = 1; r < size_; ++r) {
    const std::vector<int32_t>& theirs = global_of_rank_[r];
    buffer.resize(theirs.size() * element);
    for (size_t i = 0; i < theirs.size(); ++i)
      std::memcpy(buffer.data() + i * element, in + static_cast<size_t>(theirs[i]) * element,
                  element);
    MPI_Send(buffer.data(), static_cast<int>(theirs.size()), type.get(), r, kValuesTag, comm_);
  }
}

void FeatureExchange::GatherBytes(const void* mine, void* root, size_t element) const {
  const ElementType type(element);
  const std::vector<int32_t>& local = ownership_->owned_local;
  const char* const in = static_cast<const char*>(mine);
  if (rank_ != 0) {
    std::vector<char> buffer(local.size() * element);
    for (size_t i = 0; i < local.size(); ++i)
      std::memcpy(buffer.data() + i * element, in + static_cast<size_t>(local[i]) * element,
                  element);
    MPI_Send(buffer.data(), static_cast<int>(local.size()), type.get(), 0, kValuesTag, comm_);
    return;
  }
  char* const out = static_cast<char*>(root);
  const std::vector<int32_t>& global = ownership_->owned_global;
  for (size_t i = 0; i < local.size(); ++i)
    std::memcpy(out + static_cast<size_t>(global[i]) * element,
                in + static_cast<size_t>(local[i]) * element, element);
  std::vector<char> buffer;
  for (int r = 1; r < size_; ++r) {
    const std::vector<int32_t>& theirs = global_of_rank_[r];
    buffer.resize(theirs.size() * element);
    MPI_Recv(buffer.data(), static_cast<int>(theirs.size()), type.get(), r, kValuesTag, comm_,
             MPI_STATUS_IGNORE);
    for (size_t i = 0; i < theirs.size(); ++i)
      std::memcpy(out + static_cast<size_t>(theirs[i]) * element, buffer.data() + i * element,
                  element);
  }
}

}  // namespace graphslam::distributed
