// y += S x for the reduced pose system S (core/block_sparse_matrix.h) at the
// scale of the 10^7..10^8 stores: 10^5 poses of block size 3, each coupled to
// its 14 successors (the band the temporal chunking leaves) plus one random
// loop closure, i.e. about 30 blocks per block row of the full matrix, the
// 28.8 blocks per pose of the 10^8 store. Reports the time per product with
// the TBB product in an arena of 1 and 2 threads (wall time) and the serial
// one, and how the one-sweep product split the rows (ranges, accumulator rows,
// far blocks; core/block_sparse_matrix.h).
//
//   build/bin/block_sparse_product_benchmark --benchmark_repetitions=5
//   (add --benchmark_report_aggregates_only=true for the medians only)
#include <benchmark/benchmark.h>

#include <tbb/task_arena.h>

#include <random>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"

namespace graphslam::core {
namespace {

constexpr int kPoses = 100000;
constexpr int kBand = 14;

const BlockSparseMatrix& PoseSystem() {
  static const BlockSparseMatrix* s = [] {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> value(-1.0, 1.0);
    std::uniform_int_distribution<int> pose(0, kPoses - 1);
    std::vector<std::pair<int, int>> pairs;
    for (int i = 0; i < kPoses; ++i) {
      for (int o = 1; o <= kBand && i + o < kPoses; ++o) pairs.emplace_back(i, i + o);
      pairs.emplace_back(i, pose(rng));
    }
    auto* m = new BlockSparseMatrix(BlockSparseMatrix::FromPattern(3, kPoses, pairs));
    for (const auto& [i, k] : pairs) {
      Eigen::Matrix3d block;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) block(r, c) = value(rng);
      if (i == k) block = (block + block.transpose()).eval();
      m->AddBlock(i, k, block);
    }
    return m;
  }();
  return *s;
}

void BM_Product(benchmark::State& state) {
  const BlockSparseMatrix& s = PoseSystem();
  std::vector<double> x(static_cast<size_t>(s.num_rows()), 1.0), y(x.size(), 0.0);
  tbb::task_arena arena(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    arena.execute([&] { s.RightMultiplyAndAccumulate(x.data(), y.data()); });
    benchmark::DoNotOptimize(y.data());
  }
  state.counters["blocks"] = static_cast<double>(s.num_nonzero_blocks());
  state.counters["ranges"] = s.num_product_ranges();
  state.counters["accumulator_rows"] = static_cast<double>(s.num_accumulator_rows());
  state.counters["far_blocks"] = static_cast<double>(s.num_far_blocks());
}
BENCHMARK(BM_Product)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

void BM_ProductSerial(benchmark::State& state) {
  const BlockSparseMatrix& s = PoseSystem();
  std::vector<double> x(static_cast<size_t>(s.num_rows()), 1.0), y(x.size(), 0.0);
  for (auto _ : state) {
    s.RightMultiplyAndAccumulateSerial(x.data(), y.data());
    benchmark::DoNotOptimize(y.data());
  }
}
BENCHMARK(BM_ProductSerial)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace graphslam::core

BENCHMARK_MAIN();
