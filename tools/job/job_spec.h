// JobSpec: a batch job file (`graphslam run JOB.yaml`, docs/jobs.md) parsed
// and validated: where the outputs go, how many threads, the memory budget,
// which stages run, and the list of runs (inputs) to map together.
//
//   output: out/                  # required unless -o; relative paths are relative to
//   threads: 2                    #   the job file's folder
//   memory_limit: 2GiB            # bytes, or with KiB/MiB/GiB
//   stages: [ingest, initialize, optimize, export]   # default: all
//   solver: {max_iterations: 50, robust_kernel: cauchy:1, initialization: odometry}
//   robot_sightings: true         # MRCLAM robot-to-robot constraints (default true)
//   runs:
//     - {name: robot1, format: mrclam, path: data/MRCLAM_Dataset1, robot: 1}
//     - {name: sim, format: simulate, simulate: {poses: 2000, runs: 2, gps_every: 10}}
//
// Every error is InvalidArgument "<job file>:<line>:<column>: <what>; expected
// <what>", the line and column of the offending YAML node (yaml-cpp's Mark,
// 0-based there, 1-based here). Unknown keys are errors (a typo must not
// silently drop a setting), and so is a key given twice in one mapping
// (yaml-cpp keeps both; node[key] would silently take the first). A run name
// names files: letters, digits, '_', '-', '.', not starting with '.', at most
// 128 bytes.
//
// THREAD SAFETY: plain values and reentrant functions. ALLOCATION: O(file).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/graphslam_solver.h"
#include "core/status.h"
#include "tools/campus_simulator.h"

namespace graphslam::tools::job {

// The stages, in execution order.
enum class Stage { kIngest, kInitialize, kAssociate, kOptimize, kMap, kExport };
inline constexpr std::array<Stage, 6> kAllStages = {Stage::kIngest,   Stage::kInitialize,
                                                    Stage::kAssociate, Stage::kOptimize,
                                                    Stage::kMap,      Stage::kExport};
const char* StageName(Stage stage);

// GPS fixes of a run from a CSV file: "t,lat,lon" (degrees, WGS84) or
// "t,east,north" (metres, frame: enu). A fix is attached to the run's pose
// nearest in time if that is within max_time_difference.
struct GpsSource {
  std::string path;
  std::string frame = "wgs84";  // wgs84 or enu
  double sigma = 2.0;           // m, per axis
  double max_time_difference = 0.5;  // s
  int line = 0;  // of the gps node in the job file
};

// simulate runs: a vertical push-broom laser scan generated for every true
// pose against a 3-D world consistent with the 2-D campus (buildings on the
// blocks, the landmarks as poles, level ground; tools/job/simulated_scans.h).
struct SimulatedScanSpec {
  bool enabled = false;
  int beams = 90;            // rays over 360 degrees in the body y-z plane
  double max_range = 30.0;   // m; no return beyond
  double range_sigma = 0.02; // m
};

struct RunSpec {
  std::string name;
  std::string format;  // g2o, isam, mrclam, native, simulate
  std::string path;    // absolute (resolved against the job file's folder)
  int robot = 1;       // mrclam
  CampusSimulatorOptions simulate;  // simulate
  // simulate: no GPS fix inside this axis-aligned box [x0, y0, x1, y1] (indoors).
  std::optional<std::array<double, 4>> gps_denied_region;
  SimulatedScanSpec simulate_scans;  // simulate: scans: true, scan_beams, ...
  // mrclam: measurement noise (the format does not carry it).
  std::optional<double> range_sigma;
  std::optional<double> bearing_sigma;
  std::optional<GpsSource> gps;
  // false: the run's landmark ids are ignored (unknown correspondence): every
  // observation gets a landmark of its own and the associate stage finds
  // which are the same (partition/association/association_driver.h), within the run and
  // across runs.
  bool ids = true;
  // optional ground truth: a TUM or KITTI trajectory (tools/ground_truth.h)
  std::string ground_truth;
  std::string ground_truth_format = "auto";  // auto, tum, kitti
  std::string ground_truth_times;            // KITTI: optional times file
  // optional scan store folder (storage/scan_store.h: DIR/scans/SCANS.json)
  // whose scans' `pose` is the 0-based pose index within this run (map stage)
  std::string scans;
  int line = 0;              // of the run in the job file
};

struct SolverSpec {
  // The solver's own defaults (core::SolverOptions), so a job and
  // `graphslam solve` can never drift apart.
  int max_iterations = core::SolverOptions().max_iterations;
  double function_tolerance = core::SolverOptions().function_tolerance;
  double model_tolerance = core::SolverOptions().model_tolerance;
  std::string robust_kernel = "none";
  // auto (= incremental: the job's solve is checkpointed, so no odometry
  // probe as in `graphslam solve`), incremental, progressive, odometry.
  std::string initialization = "auto";
  std::string linear_solver = "auto";
  // Repair non-positive-definite information of g2o / TORO runs instead of
  // rejecting them (core/information_repair.h); counted per run in the report.
  bool repair_information = false;
};

// The map stage (tools/job/job_map.h): OctoMap fusion of every run's scans
// moved by the optimized poses.
struct MapSpec {
  double resolution = 0.2;     // m, OctoMap leaf edge
  double max_range = 30.0;     // m, rays cut here (no endpoint)
  double pcd_voxel = 0.0;      // m, map.pcd voxel edge; 0: resolution
  double sensor_height = 1.5;  // m: a 2-D pose (x, y, theta) is lifted to the
                               // sensor pose (x, y, sensor_height, yaw theta)
};

struct JobSpec {
  std::string path;         // the job file
  std::string output;       // absolute output folder
  int threads = 0;          // 0: all cores
  int64_t memory_limit = 0; // bytes; 0: none
  std::vector<Stage> stages;  // in execution order
  SolverSpec solver;
  MapSpec map;
  // simulate runs: also solve the job without GPS and report the indoor error
  // of both (the paper's Figure 6 comparison).
  bool compare_without_gps = false;
  // MRCLAM runs of one dataset: a sighting of another run's robot becomes a
  // robot-to-robot constraint (tools/job/robot_sightings.h); false leaves
  // them out, so only shared landmarks tie the runs.
  bool robot_sightings = true;
  std::vector<RunSpec> runs;

  bool HasStage(Stage stage) const;
};

// Parses YAML text; `path` names the file in messages and anchors relative paths.
StatusOr<JobSpec> ParseJobSpec(const std::string& text, const std::string& path);
// Reads and parses a job file (NotFound / IOError if it cannot be read).
StatusOr<JobSpec> ReadJobSpec(const std::string& path);

}  // namespace graphslam::tools::job
