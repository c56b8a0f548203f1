// SerialOpenMpRegions: OpenMP regions run on the calling thread while one
// lives, and through libgomp with their threads otherwise.
#include "core/serial_openmp.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <mutex>
#include <thread>
#include <vector>

// GCC's entry point for `#pragma omp parallel` (core/serial_openmp.h).
extern "C" void GOMP_parallel(void (*fn)(void*), void* data, unsigned num_threads,
                              unsigned flags);

namespace graphslam::core {
namespace {

struct Calls {
  std::mutex mutex;
  std::vector<std::thread::id> threads;
  std::vector<int> team_sizes;
  std::vector<int> thread_numbers;
};

void RecordCall(void* data) {
  auto* calls = static_cast<Calls*>(data);
  const std::lock_guard<std::mutex> lock(calls->mutex);
  calls->threads.push_back(std::this_thread::get_id());
  calls->team_sizes.push_back(omp_get_num_threads());
  calls->thread_numbers.push_back(omp_get_thread_num());
}

TEST(SerialOpenMpRegions, RegionsRunOnceOnTheCallingThreadWhileInScope) {
  const int before = omp_get_max_active_levels();
  Calls calls;
  {
    const SerialOpenMpRegions serial;
    EXPECT_EQ(omp_get_max_active_levels(), 0);
    GOMP_parallel(RecordCall, &calls, 4, 0);  // num_threads(4), as CHOLMOD's
  }
  EXPECT_EQ(omp_get_max_active_levels(), before);
  ASSERT_EQ(calls.threads.size(), 1u);
  EXPECT_EQ(calls.threads[0], std::this_thread::get_id());
  EXPECT_EQ(calls.team_sizes[0], 1);
  EXPECT_EQ(calls.thread_numbers[0], 0);
}

TEST(SerialOpenMpRegions, RegionsOutsideTheScopeGetTheirThreads) {
  // The environment can make libgomp's regions smaller than asked for.
  if (omp_get_max_active_levels() == 0 || omp_get_thread_limit() < 2 || omp_get_dynamic())
    GTEST_SKIP() << "OMP_MAX_ACTIVE_LEVELS, OMP_THREAD_LIMIT or OMP_DYNAMIC set";
  Calls calls;
  GOMP_parallel(RecordCall, &calls, 2, 0);
  ASSERT_EQ(calls.threads.size(), 2u);
  EXPECT_EQ(calls.team_sizes[0], 2);
  EXPECT_EQ(calls.team_sizes[1], 2);
  EXPECT_NE(calls.threads[0], calls.threads[1]);
  EXPECT_EQ(calls.thread_numbers[0] + calls.thread_numbers[1], 1);  // threads 0 and 1
}

}  // namespace
}  // namespace graphslam::core
