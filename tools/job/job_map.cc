#include "tools/job/job_map.h"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <set>
#include <vector>

#include "storage/atomic_file.h"
#include "storage/env.h"
#include "storage/native_log_reader.h"
#include "storage/native_log_scans.h"
#include "storage/scan_store.h"
#include "tools/campus_simulator.h"
#include "tools/job/job_memory_budget.h"
#include "tools/job/simulated_scans.h"
#include "tools/map_builder.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The scans of all runs, chunk after chunk, in run order; scans of a scan
// folder are moved to the merged pose numbering and get their run id.
class JobScanSource : public map::ScanSource {
 public:
  struct Part {
    std::unique_ptr<map::DiskScanStore> store;
    int64_t pose_offset = 0;
    int32_t run = -1;  // -1: keep the scans' own (simulated: already merged ids)
  };
  // Only the scans of runs in `component` (runs[r].component) are returned.
  JobScanSource(std::vector<Part> parts, const std::vector<RunInfo>* runs, int32_t component,
                ProgressDisplay* display)
      : parts_(std::move(parts)), runs_(runs), component_(component), display_(display) {
    for (size_t p = 0; p < parts_.size(); ++p) {
      for (int64_t c = 0; c < parts_[p].store->NumChunks(); ++c) chunks_.emplace_back(p, c);
      total_scans_ += parts_[p].store->total_scans();
      total_points_ += parts_[p].store->total_points();
    }
  }
  int64_t NumChunks() const override { return static_cast<int64_t>(chunks_.size()); }
  Status Load(int64_t index, std::vector<map::Scan>* scans) const override {
    const auto [p, c] = chunks_[static_cast<size_t>(index)];
    const Part& part = parts_[p];
    GS_RETURN_IF_ERROR(part.store->Load(c, scans));
    for (map::Scan& scan : *scans) {
      if (scan.pose >= 0) scan.pose += part.pose_offset;
      if (part.run >= 0) scan.run = part.run;
    }
    done_scans_ += static_cast<int64_t>(scans->size());
    std::erase_if(*scans, [&](const map::Scan& scan) {
      return scan.run < 0 || scan.run >= static_cast<int32_t>(runs_->size()) ||
             (*runs_)[static_cast<size_t>(scan.run)].component != component_;
    });
    if (display_ != nullptr) display_->Update("map", done_scans_, total_scans_);
    return Status::Ok();
  }
  int64_t total_scans() const { return total_scans_; }
  int64_t total_points() const { return total_points_; }

 private:
  std::vector<Part> parts_;
  std::vector<std::pair<size_t, int64_t>> chunks_;
  const std::vector<RunInfo>* runs_;
  int32_t component_;
  ProgressDisplay* display_;
  int64_t total_scans_ = 0, total_points_ = 0;
  mutable int64_t done_scans_ = 0;
};

std::string SimulatedScanDir(const std::string& work, const std::string& run) {
  return (fs::path(work) / "scans" / run).string();
}

// The merged index of the run named `name`, or -1.
int RunIndex(const JobData& data, const std::string& name) {
  for (size_t r = 0; r < data.runs.size(); ++r)
    if (data.runs[r].name == name) return static_cast<int>(r);
  return -1;
}

// The first merged run of a job run (a simulate run with runs: N > 1 becomes
// <name>_1 .. <name>_N).
int FirstRunOf(const JobData& data, const RunSpec& spec) {
  const int direct = RunIndex(data, spec.name);
  return direct >= 0 ? direct : RunIndex(data, spec.name + "_1");
}

// In 1 MiB blocks: a map file may be as large as the fusion's tile budget,
// half the job's memory_limit or more, and must not be held whole.
Status CopyAtomically(const std::string& from, const std::string& to) {
  storage::Env* env = storage::Env::Default();
  if (!env->FileExists(from))
    return Status::NotFound(from + ": missing (did the map stage complete?)");
  GS_ASSIGN_OR_RETURN(std::unique_ptr<storage::ReadableFile> in, env->NewReadableFile(from));
  std::string block(size_t{1} << 20, '\0');
  return storage::WriteFileAtomically(env, to, [&](storage::WritableFile* file) -> Status {
    while (true) {
      GS_ASSIGN_OR_RETURN(const size_t n, in->Read(block.size(), block.data()));
      if (n == 0) return Status::Ok();
      GS_RETURN_IF_ERROR(file->Append(std::string_view(block.data(), n)));
    }
  });
}

}  // namespace

int64_t ScanChunkBytes(int64_t memory_limit) {
  if (memory_limit <= 0) return int64_t{16} << 20;
  return std::clamp<int64_t>(memory_limit / 64, int64_t{256} << 10, int64_t{16} << 20);
}

namespace {

// A native log run without a scans: folder: its SCAN records' .pcd files are
// copied at ingest into `work`/scans/<run>/ (CopyLogScans).
bool TakesLogScans(const RunSpec& run) { return run.format == "native" && run.scans.empty(); }

// The scans of the native log's SCAN records (its .pcd files read by PCL, one
// scan at a time) into a scan store at `dir`; the number copied (0 and no
// store when the log names none).
StatusOr<int64_t> CopyLogScans(const std::string& log, const std::string& dir, int64_t chunk_bytes) {
  std::vector<storage::NativeLogScan> records;
  // Only the poses and SCAN records are used here: information that is not
  // positive definite is judged where the run is read (LoadJobData,
  // solver.repair_information), not by this copy.
  core::InformationRepairs ignored;
  StatusOr<core::Problem2d> problem = storage::ReadNativeLog(log, &records, &ignored);
  if (!problem.ok()) return problem.status();
  if (records.empty()) return int64_t{0};
  std::vector<core::Pose3> poses;
  for (const storage::NativeLogScan& record : records)
    poses.push_back(map::LiftLoggedPose(problem->poses[static_cast<size_t>(record.pose)]));
  StatusOr<std::unique_ptr<map::NativeLogScanSource>> source =
      map::NativeLogScanSource::FromRecords(log, std::move(records), std::move(poses));
  if (!source.ok()) return source.status();
  StatusOr<std::unique_ptr<map::ScanStoreWriter>> writer = map::ScanStoreWriter::Create(dir, chunk_bytes);
  if (!writer.ok()) return writer.status();
  std::vector<map::Scan> scans;
  for (int64_t k = 0; k < (*source)->NumChunks(); ++k) {
    GS_RETURN_IF_ERROR((*source)->Load(k, &scans));
    for (const map::Scan& scan : scans) GS_RETURN_IF_ERROR((*writer)->Add(scan));
  }
  GS_RETURN_IF_ERROR((*writer)->Finish());
  return (*source)->NumChunks();
}

}  // namespace

bool JobHasScans(const JobSpec& spec, const std::string& work) {
  for (const RunSpec& run : spec.runs) {
    if (!run.scans.empty() || (run.format == "simulate" && run.simulate_scans.enabled)) return true;
    if (!work.empty() && TakesLogScans(run) &&
        map::DiskScanStore::Exists(SimulatedScanDir(work, run.name)))
      return true;
  }
  return false;
}

StatusOr<int64_t> WriteSimulatedScans(const JobSpec& spec, const JobData& data,
                                      const std::string& work) {
  int64_t written = 0;
  for (const RunSpec& run : spec.runs) {
    if (TakesLogScans(run)) {
      // A restart of the stage rewrites the copy from nothing.
      GS_RETURN_IF_ERROR(
          storage::Env::Default()->RemoveTree(SimulatedScanDir(work, run.name)));
      StatusOr<int64_t> copied =
          CopyLogScans(run.path, SimulatedScanDir(work, run.name), ScanChunkBytes(spec.memory_limit));
      if (!copied.ok()) return copied.status();
      written += *copied;
      continue;
    }
    if (run.format != "simulate" || !run.simulate_scans.enabled) continue;
    // The 2-D campus again (deterministic in its seed): its true poses and
    // landmarks are the world the laser sees.
    StatusOr<SimulatedCampus> campus = SimulateCampus(run.simulate);
    if (!campus.ok()) return campus.status();
    const int first_run = FirstRunOf(data, run);
    if (first_run < 0)
      return Status::Corruption("run '" + run.name + "' is missing from the ingested runs");
    const map::Campus3d world = MakeCampusWorld3d(run.simulate, *campus, spec.map.sensor_height);
    const std::string dir = SimulatedScanDir(work, run.name);
    StatusOr<std::unique_ptr<map::ScanStoreWriter>> writer =
        map::ScanStoreWriter::Create(dir, ScanChunkBytes(spec.memory_limit));
    if (!writer.ok()) return writer.status();
    GS_RETURN_IF_ERROR(SimulateCampusScans(
        world, campus->true_poses, campus->run_of_pose, data.runs[first_run].first_pose, first_run,
        run.simulate_scans, spec.map.sensor_height, run.simulate.seed,
        [&](map::Scan&& scan) {
          ++written;
          return (*writer)->Add(scan);
        }));
    GS_RETURN_IF_ERROR((*writer)->Finish());
  }
  return written;
}

namespace {

// The scan stores of the job (opened afresh for every component's pass), and
// the components whose runs have scans.
Status OpenScanParts(const JobSpec& spec, const JobData& data, const std::string& work,
                     std::vector<JobScanSource::Part>* parts, std::set<int32_t>* components) {
  parts->clear();
  for (const RunSpec& run : spec.runs) {
    JobScanSource::Part part;
    if (run.format == "simulate" && run.simulate_scans.enabled) {
      StatusOr<std::unique_ptr<map::DiskScanStore>> store =
          map::DiskScanStore::Open(SimulatedScanDir(work, run.name));
      if (!store.ok()) return store.status();
      part.store = std::move(store).value();
      const int first = FirstRunOf(data, run);
      if (first < 0) return Status::Corruption("run '" + run.name + "' is missing from the ingested runs");
      for (int k = 0; k < std::max(1, run.simulate.runs); ++k)
        components->insert(data.runs[static_cast<size_t>(first + k)].component);
    } else if (TakesLogScans(run) && map::DiskScanStore::Exists(SimulatedScanDir(work, run.name))) {
      // The log's scans, copied at ingest: pose = index within the run.
      const int r = RunIndex(data, run.name);
      if (r < 0) return Status::Corruption("run '" + run.name + "' is missing from the ingested runs");
      StatusOr<std::unique_ptr<map::DiskScanStore>> store =
          map::DiskScanStore::Open(SimulatedScanDir(work, run.name));
      if (!store.ok()) return store.status();
      part.store = std::move(store).value();
      part.pose_offset = data.runs[static_cast<size_t>(r)].first_pose;
      part.run = r;
      components->insert(data.runs[static_cast<size_t>(r)].component);
    } else if (!run.scans.empty()) {
      const int r = RunIndex(data, run.name);
      if (r < 0)
        return Status::InvalidArgument(spec.path + ":" + std::to_string(run.line) + ": run '" +
                                       run.name + "': a scan folder needs a single-run input");
      StatusOr<std::unique_ptr<map::DiskScanStore>> store = map::DiskScanStore::Open(run.scans);
      if (!store.ok())
        return Status::InvalidArgument(spec.path + ":" + std::to_string(run.line) + ": run '" +
                                       run.name + "' scans: " + store.status().message());
      part.store = std::move(store).value();
      part.pose_offset = data.runs[static_cast<size_t>(r)].first_pose;
      part.run = r;
      components->insert(data.runs[static_cast<size_t>(r)].component);
    } else {
      continue;
    }
    parts->push_back(std::move(part));
  }
  return Status::Ok();
}

// The map options of one component's map STEM.{bt,pcd} in `work`: the
// job's resolution, range and voxel, and what --memory-limit leaves beside
// the problem (tools/job/job_memory_budget.h).
StatusOr<map::MapOptions> ComponentMapOptions(const JobSpec& spec, const JobData& data,
                                              const std::string& work, const std::string& stem) {
  map::MapOptions options;
  options.fusion.resolution = spec.map.resolution;
  options.fusion.max_range = spec.map.max_range;
  options.bt_path = (fs::path(work) / (stem + ".bt")).string();
  options.pcd_path = (fs::path(work) / (stem + ".pcd")).string();
  options.pcd_voxel = spec.map.pcd_voxel;
  if (spec.memory_limit > 0) {
    GS_ASSIGN_OR_RETURN(const JobBudget budget,
                        BudgetJob(spec.memory_limit, JobSizeOf(spec, data.problem)));
    options.memory_budget_bytes = budget.map_tile_bytes;
    options.batch_points = budget.map_batch_points;
  }
  return options;
}

// One map's entry of map.json.
json MapEntry(int32_t component, const JobData& data, const map::MapSummary& summary,
              const map::MapOptions& options, const json& map_files) {
  json runs = json::array();
  for (const RunInfo& run : data.runs)
    if (run.component == component) runs.push_back(run.name);
  return {{"component", component},
          {"runs", runs},
          {"scans", summary.scans},
          {"points", summary.points},
          {"pcd_points", summary.pcd_points},
          {"occupied_leaves", summary.occupied_leaves},
          {"free_leaves", summary.free_leaves},
          {"tiles", summary.tiles},
          {"tiled_output", summary.tiled_output},
          {"tree_bytes", summary.tree_bytes},
          {"memory_budget_bytes", options.memory_budget_bytes},
          {"batch_points", options.batch_points},
          {"resolution_m", options.fusion.resolution},
          {"max_range_m", options.fusion.max_range},
          {"fusion_seconds", summary.fusion_seconds},
          {"points_per_second", summary.points_per_second},
          {"files", map_files}};
}

}  // namespace

StatusOr<json> BuildJobMap(const JobSpec& spec, const JobData& data, const std::string& work,
                           ProgressDisplay* display) {
  std::vector<JobScanSource::Part> parts;
  std::set<int32_t> components;
  GS_RETURN_IF_ERROR(OpenScanParts(spec, data, work, &parts, &components));

  std::vector<core::Pose3> poses;
  poses.reserve(data.problem.poses.size());
  for (const core::Pose2& pose : data.problem.poses)
    poses.push_back(LiftPose(pose, spec.map.sensor_height));

  json maps = json::array();
  json files = json::array();
  for (const int32_t component : components) {
    // Each component is in its own frame: its own map (component 0: map.*).
    const std::string stem = component == 0 ? "map" : "map_c" + std::to_string(component);
    std::set<int32_t> same;
    if (parts.empty()) GS_RETURN_IF_ERROR(OpenScanParts(spec, data, work, &parts, &same));
    JobScanSource source(std::move(parts), &data.runs, component, display);
    parts.clear();

    GS_ASSIGN_OR_RETURN(const map::MapOptions options,
                        ComponentMapOptions(spec, data, work, stem));
    // A restart after kill -9 starts from nothing: no stale spill or tiles.
    for (const char* scratch : {".spill", ".tiles"})
      GS_RETURN_IF_ERROR(
          storage::Env::Default()->RemoveTree((fs::path(work) / (stem + scratch)).string()));
    StatusOr<map::MapSummary> summary = map::BuildMap(options, source, &poses);
    if (!summary.ok()) return summary.status();
    if (display != nullptr) display->Finish();

    json map_files = json::array();
    map_files.push_back(summary->tiled_output ? stem + ".tiles/" : stem + ".bt");
    map_files.push_back(stem + ".pcd");
    for (const json& f : map_files) files.push_back(f);
    maps.push_back(MapEntry(component, data, *summary, options, map_files));
  }
  // The first map's figures at the top; every map (one per component with
  // scans) in `maps`; all files in `files`.
  json result = maps.empty() ? json::object() : maps[0];
  result["files"] = files;
  result["maps"] = maps;
  int64_t scans = 0, points = 0;
  for (const json& m : maps) {
    scans += m["scans"].get<int64_t>();
    points += m["points"].get<int64_t>();
  }
  result["scans_all_maps"] = scans;
  result["points_all_maps"] = points;
  GS_RETURN_IF_ERROR(storage::WriteStringAtomically(
      storage::Env::Default(), (fs::path(work) / "map.json").string(), result.dump(1) + "\n"));
  return result;
}

StatusOr<std::vector<std::string>> ExportJobMap(const std::string& work, const std::string& output) {
  json summary;
  {
    GS_ASSIGN_OR_RETURN(const std::string text,
                        storage::ReadFileToString(
                            storage::Env::Default(), (fs::path(work) / "map.json").string(),
                            work + "/map.json: missing (did the map stage complete?)"));
    summary = json::parse(text, nullptr, false);
    if (summary.is_discarded() || !summary.contains("files"))
      return Status::Corruption(work + "/map.json: not a map summary");
  }
  std::vector<std::string> written;
  for (const json& entry : summary["files"]) {
    const std::string name = entry.get<std::string>();
    if (!name.empty() && name.back() == '/') {  // a tiled map
      const fs::path tiles = fs::path(work) / name;
      GS_RETURN_IF_ERROR(storage::Env::Default()->CreateDir((fs::path(output) / name).string()));
      GS_ASSIGN_OR_RETURN(const std::vector<std::string> names,
                          storage::Env::Default()->ListDir(tiles.string()));
      for (const std::string& file : names)
        GS_RETURN_IF_ERROR(CopyAtomically((tiles / file).string(),
                                          (fs::path(output) / name / file).string()));
    } else {
      GS_RETURN_IF_ERROR(CopyAtomically((fs::path(work) / name).string(),
                                        (fs::path(output) / name).string()));
    }
    written.push_back(name);
  }
  return written;
}

}  // namespace graphslam::tools::job
