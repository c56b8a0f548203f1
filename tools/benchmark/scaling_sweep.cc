#include "tools/benchmark/scaling_sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/logging.h"
#include "storage/atomic_file.h"
#include "storage/checksummed_json.h"
#include "storage/directory_lock.h"
#include "storage/env.h"
#include "storage/stop_point.h"
#include "tools/benchmark/child_process.h"
#include "tools/benchmark/scaling_report.h"

namespace graphslam::tools::benchmark {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kStateFormat = "graphslam-benchmark-state";
constexpr const char* kWorkFolder = ".benchmark";

std::string Number(double value) {
  std::ostringstream text;
  text.precision(17);
  text << value;
  return text.str();
}

json ProportionJson(const ScalingProportion& p) {
  return {{"poses_per_feature", p.poses_per_feature},
          {"runs", p.runs},
          {"gps_every", p.gps_every},
          {"speed", p.speed},
          {"landmark_spacing", {p.landmark_spacing_min, p.landmark_spacing_max}},
          {"sensor_range", p.sensor_range},
          {"seed", p.seed},
          {"initialization", p.initialization.empty() ? "default" : p.initialization}};
}

json RowJson(const ScalingRow& r) {
  return {{"features", r.features},
          {"poses", r.poses},
          {"observations", r.observations},
          {"simulate_seconds", r.simulate_seconds},
          {"ingest_seconds", r.ingest_seconds},
          {"solve_seconds", r.solve_seconds},
          {"ingest_cpu_seconds", r.ingest_cpu_seconds},
          {"solve_cpu_seconds", r.solve_cpu_seconds},
          {"ingest_peak_rss_bytes", r.ingest_peak_rss_bytes},
          {"solve_peak_rss_bytes", r.solve_peak_rss_bytes},
          {"store_bytes", r.store_bytes},
          {"iterations", r.iterations},
          {"seconds_per_iteration", r.seconds_per_iteration},
          {"chi2_per_dof", r.chi2_per_dof},
          {"termination", r.termination}};
}

ScalingRow RowFromJson(const json& j) {
  ScalingRow r;
  r.features = j.at("features").get<int64_t>();
  r.poses = j.at("poses").get<int64_t>();
  r.observations = j.at("observations").get<int64_t>();
  r.simulate_seconds = j.at("simulate_seconds").get<double>();
  r.ingest_seconds = j.at("ingest_seconds").get<double>();
  r.solve_seconds = j.at("solve_seconds").get<double>();
  r.ingest_cpu_seconds = j.at("ingest_cpu_seconds").get<double>();
  r.solve_cpu_seconds = j.at("solve_cpu_seconds").get<double>();
  r.ingest_peak_rss_bytes = j.at("ingest_peak_rss_bytes").get<int64_t>();
  r.solve_peak_rss_bytes = j.at("solve_peak_rss_bytes").get<int64_t>();
  r.store_bytes = j.at("store_bytes").get<int64_t>();
  r.iterations = j.at("iterations").get<int>();
  r.seconds_per_iteration = j.at("seconds_per_iteration").get<double>();
  r.chi2_per_dof = j.at("chi2_per_dof").get<double>();
  r.termination = j.at("termination").get<std::string>();
  return r;
}

// OUT may be written if it is missing, empty, or a benchmark folder.
Status CheckOutputFolder(const std::string& output) {
  storage::Env* env = storage::Env::Default();
  const storage::FileKind kind = env->KindOf(output);
  if (kind == storage::FileKind::kMissing) return Status::Ok();
  if (kind != storage::FileKind::kDirectory)
    return Status::InvalidArgument(output + ": not a folder; expected the benchmark's output folder");
  if (env->KindOf((fs::path(output) / kWorkFolder).string()) == storage::FileKind::kDirectory)
    return Status::Ok();
  GS_ASSIGN_OR_RETURN(const std::vector<std::string> names, env->ListDir(output));
  for (const std::string& name : names) {
    if (name == storage::kDirectoryLockName) continue;
    return Status::InvalidArgument(output + ": folder is not empty and is not a graphslam "
                                   "benchmark folder (it holds '" + name +
                                   "'); nothing was written or deleted");
  }
  return Status::Ok();
}

StatusOr<std::vector<ScalingRow>> ReadState(const std::string& path,
                                            const ScalingProportion& proportion) {
  StatusOr<std::string> text = storage::ReadFileToString(storage::Env::Default(), path);
  if (!text.ok() && text.status().IsNotFound()) return std::vector<ScalingRow>();
  if (!text.ok()) return text.status();
  json state = json::parse(*text, nullptr, /*allow_exceptions=*/false);
  if (state.is_discarded() || !state.is_object())
    return Status::Corruption(path + ": not a JSON object; expected the benchmark's state");
  GS_RETURN_IF_ERROR(storage::UnsealJson(&state, path));
  if (state.value("format", "") != kStateFormat)
    return Status::Corruption(path + ": format is not '" + std::string(kStateFormat) + "'");
  if (state.value("proportion", json()) != ProportionJson(proportion))
    return Status::InvalidArgument(path + ": the benchmark there has the proportion " +
                                   state.value("proportion", json()).dump() + ", not " +
                                   ProportionJson(proportion).dump() +
                                   "; run without --resume to start over");
  std::vector<ScalingRow> rows;
  try {
    for (const json& row : state.at("rows")) rows.push_back(RowFromJson(row));
  } catch (const json::exception& e) {
    return Status::Corruption(path + ": malformed row: " + e.what());
  }
  return rows;
}

Status WriteState(const std::string& path, const ScalingProportion& proportion,
                  const std::vector<ScalingRow>& rows) {
  json state = {{"format", kStateFormat}, {"version", 1}, {"proportion", ProportionJson(proportion)}};
  state["rows"] = json::array();
  for (const ScalingRow& row : rows) state["rows"].push_back(RowJson(row));
  storage::SealJson(&state);
  return storage::WriteStringAtomically(storage::Env::Default(), path, state.dump(1) + "\n");
}

// The bytes of the files below `dir`; what cannot be listed or sized counts 0.
int64_t BytesUnder(const fs::path& dir) {
  storage::Env* env = storage::Env::Default();
  const StatusOr<std::vector<std::string>> files = env->ListTree(dir.string());
  if (!files.ok()) return 0;
  int64_t bytes = 0;
  for (const std::string& file : *files) {
    const StatusOr<uint64_t> size = env->FileSize((dir / file).string());
    if (size.ok()) bytes += static_cast<int64_t>(*size);
  }
  return bytes;
}

// Runs one step; a failing step is an error naming the size, step and log.
StatusOr<ChildCost> Step(const std::string& step, int64_t features,
                         const std::vector<std::string>& args, const fs::path& work,
                         bool quiet) {
  const std::string log = (work / (step + ".log")).string();
  if (!quiet) std::fprintf(stderr, "[benchmark] %lld features: %s\n",
                           static_cast<long long>(features), step.c_str());
  GS_ASSIGN_OR_RETURN(ChildCost cost, RunChildProcess(args, log));
  // A solve at its iteration cap (exit 4) still wrote its report: the row
  // shows the termination.
  if (cost.exit_code != 0 && !(step == "solve" && cost.exit_code == 4))
    return Status::IOError("benchmark of " + std::to_string(features) + " features: " + step +
                           " exited with " + std::to_string(cost.exit_code) + "; see " + log);
  return cost;
}

StatusOr<ScalingRow> RunSize(const ScalingSweepOptions& options, int64_t features,
                             const fs::path& work) {
  const ScalingProportion& p = options.proportion;
  storage::Env* env = storage::Env::Default();
  GS_RETURN_IF_ERROR(env->RemoveTree(work.string()));  // an interrupted size starts over
  GS_RETURN_IF_ERROR(env->CreateDir(work.string()));
  ScalingRow row;
  row.features = features;
  row.poses = PosesFor(p, features);
  const fs::path sim = work / "sim";
  const fs::path store = work / "store";
  const fs::path report = work / "solve.json";
  GS_ASSIGN_OR_RETURN(
      const ChildCost simulate,
      Step("simulate", features,
           {"simulate", "-o", sim.string(), "--features", std::to_string(features), "--poses",
            std::to_string(row.poses), "--runs", std::to_string(p.runs), "--gps-every",
            std::to_string(p.gps_every), "--speed", Number(p.speed), "--landmark-spacing",
            Number(p.landmark_spacing_min), Number(p.landmark_spacing_max), "--sensor-range",
            Number(p.sensor_range), "--seed", std::to_string(p.seed), "--streaming", "--compress",
            "-q"},
           work, options.quiet));
  GS_ASSIGN_OR_RETURN(const ChildCost ingest,
                      Step("ingest", features,
                           {"ingest", (sim / "log.graphslam.zst").string(), "-o", store.string(),
                            "-q"},
                           work, options.quiet));
  (void)env->RemoveTree(sim.string());  // the store is the input from here on
  row.store_bytes = BytesUnder(store);
  std::vector<std::string> solve_args = {"solve", store.string(), "--report", report.string(),
                                         "-q"};
  if (!p.initialization.empty()) {
    solve_args.push_back("--initialization");
    solve_args.push_back(p.initialization);
  }
  GS_ASSIGN_OR_RETURN(const ChildCost solve,
                      Step("solve", features, solve_args, work, options.quiet));
  const StatusOr<std::string> report_text = storage::ReadFileToString(env, report.string());
  const json r = json::parse(report_text.ok() ? *report_text : std::string(), nullptr,
                             /*allow_exceptions=*/false);
  if (r.is_discarded() || !r.is_object())
    return Status::Corruption(report.string() + ": the solve wrote no readable report");
  row.simulate_seconds = simulate.wall_seconds;
  row.ingest_seconds = ingest.wall_seconds;
  row.solve_seconds = solve.wall_seconds;
  row.ingest_cpu_seconds = ingest.cpu_seconds;
  row.solve_cpu_seconds = solve.cpu_seconds;
  row.ingest_peak_rss_bytes = ingest.peak_rss_bytes;
  row.solve_peak_rss_bytes = solve.peak_rss_bytes;
  row.observations = r.value("observations", int64_t{0});
  row.iterations = r.value("iterations", 0);
  row.termination = r.value("termination", std::string());
  const double optimize = r.value("stage_seconds", json::object()).value("optimize", 0.0);
  row.seconds_per_iteration = optimize / std::max(1, row.iterations);
  const double dof = r.value("residual_dimension", 0.0) - r.value("unknowns", 0.0);
  row.chi2_per_dof = dof > 0 ? r.value("final_chi2", 0.0) / dof : 0.0;
  if (!options.keep_stores) (void)env->RemoveTree(store.string());
  return row;
}

}  // namespace

int64_t PosesFor(const ScalingProportion& proportion, int64_t features) {
  const double poses = std::round(static_cast<double>(features) * proportion.poses_per_feature);
  return std::max<int64_t>(2 * proportion.runs, static_cast<int64_t>(poses));
}

Status RunScalingSweep(const ScalingSweepOptions& options, std::vector<ScalingRow>* rows) {
  GS_RETURN_IF_ERROR(CheckOutputFolder(options.output));
  GS_RETURN_IF_ERROR(
      storage::Env::Default()->CreateDir((fs::path(options.output) / kWorkFolder).string()));
  GS_ASSIGN_OR_RETURN(storage::DirectoryLock lock,
                      storage::DirectoryLock::Acquire(options.output,
                                                      storage::DirectoryLock::Mode::kExclusive));
  const fs::path work = fs::path(options.output) / kWorkFolder;
  const std::string state_path = (work / "state.json").string();
  rows->clear();
  if (options.resume) {
    GS_ASSIGN_OR_RETURN(*rows, ReadState(state_path, options.proportion));
  } else {
    if (storage::Env::Default()->FileExists(state_path))
      GS_RETURN_IF_ERROR(storage::Env::Default()->RemoveFile(state_path));
  }
  std::vector<int64_t> sizes = options.features;
  std::sort(sizes.begin(), sizes.end());
  sizes.erase(std::unique(sizes.begin(), sizes.end()), sizes.end());
  for (const int64_t features : sizes) {
    const auto done = std::find_if(rows->begin(), rows->end(),
                                   [&](const ScalingRow& r) { return r.features == features; });
    if (done != rows->end()) {
      GS_LOG(INFO, "benchmark: %lld features done before; kept", static_cast<long long>(features));
      continue;
    }
    std::string name = "n";
    name.append(std::to_string(features));  // not "n" + ...: GCC 12's false -Wrestrict
    const fs::path size_work = work / name;
    GS_ASSIGN_OR_RETURN(ScalingRow row, RunSize(options, features, size_work));
    rows->push_back(row);
    std::sort(rows->begin(), rows->end(),
              [](const ScalingRow& a, const ScalingRow& b) { return a.features < b.features; });
    GS_RETURN_IF_ERROR(WriteState(state_path, options.proportion, *rows));
    GS_RETURN_IF_ERROR(WriteScalingResults(options.output, *rows, ProportionJson(options.proportion)));
    storage::StopPointAtCountForTests("benchmark_size_done", features);
  }
  return WriteScalingResults(options.output, *rows, ProportionJson(options.proportion));
}

}  // namespace graphslam::tools::benchmark
