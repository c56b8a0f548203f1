// checkpoint_memory: the peak-RSS rise of writing one streaming-solve
// checkpoint with the PCG state of P poses (docs/history/benchmarks-notebook-2026-11.md, "Checkpoint
// PCG state and feature ids off the heap"): 3P pose values, the 3P-value
// warm start and the P-entry forest, no features. Compares the version-4
// checkpoint (poses and PCG state in a binary state file,
// storage/solver_state_file.h) with the
// JSON of versions 1-3 (WriteSolverCheckpoint: the same poses and "pcg"
// object as the version-3 JSON). Peak RSS is read from /proc/self/status
// (VmHWM), reset before each write through /proc/self/clear_refs.
//
//   checkpoint_memory DIR [POSES]     (default 1000000)
#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>

#include "storage/solver_checkpoint.h"

namespace {

long StatusKb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0) return std::stol(line.substr(line.find(':') + 1));
  return -1;
}

void ResetPeak() { std::ofstream("/proc/self/clear_refs") << "5"; }

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: checkpoint_memory DIR [POSES]\n");
    return 1;
  }
  const std::string dir = argv[1];
  const int poses = argc > 2 ? std::stoi(argv[2]) : 1000000;
  namespace gs = graphslam;
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0.0, 100.0);
  gs::core::SolverCheckpoint c;
  c.iterations = 1;
  c.trust_region_radius = 1e4;
  c.decrease_factor = 2.0;
  c.initial_chi2 = c.chi2 = 1e9;
  for (int i = 0; i < poses; ++i) c.poses.emplace_back(n(rng), n(rng), n(rng) * 1e-2);
  c.pcg.present = true;
  c.pcg.eta = 0.1;
  c.pcg.have_previous = true;
  for (int i = 0; i < 3 * poses; ++i) c.pcg.previous_x.push_back(n(rng) * 1e-3);
  for (int i = 0; i < poses; ++i) {
    c.pcg.forest_order.push_back(poses - 1 - i);
    c.pcg.forest_parent.push_back(i == 0 ? -1 : i - 1);
  }
  const auto measure = [&](const char* name, const auto& write) {
    ResetPeak();
    const long before = StatusKb("VmRSS:");
    const auto start = std::chrono::steady_clock::now();
    const gs::Status status = write();
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!status.ok()) {
      std::fprintf(stderr, "%s: %s\n", name, status.ToString().c_str());
      return false;
    }
    std::printf("%-28s rss before %7ld kB, peak while writing %7ld kB (+%ld kB), %.2f s\n", name,
                before, StatusKb("VmHWM:"), StatusKb("VmHWM:") - before, seconds);
    return true;
  };
  std::printf("%d poses, %zu warm-start values, %zu forest entries\n", poses,
              c.pcg.previous_x.size(), c.pcg.forest_order.size());
  const bool ok =
      measure("version 4 (state file)",
              [&] {
                return gs::storage::WriteSolverCheckpointWithFeatureFile(
                    gs::storage::Env::Default(), dir + "/v4.json", "in", c);
              }) &&
      measure("version 2-3 (JSON)", [&] {
        return gs::storage::WriteSolverCheckpoint(gs::storage::Env::Default(),
                                                  dir + "/v2.json", "in", c);
      });
  return ok ? 0 : 1;
}
