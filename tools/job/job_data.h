// Loading the runs of a job into ONE problem, and splitting it into the
// independent pieces that can be solved.
//
// Merge. Runs are appended in job order; every run keeps its own frame (its
// poses' guesses are those of its input). Features with the same id in two
// runs are the same landmark (known correspondences); that is what ties runs
// together, with GPS and robot sightings. Pose ids are renumbered 0..P-1 in run order, shifted
// past the largest feature id when they would collide with one (g2o keeps
// poses and features in one id space).
//
// GPS. A run's `gps:` CSV ("t,lat,lon" in degrees, or "t,east,north" in
// metres with frame: enu; header and '#' lines skipped) becomes GPS
// constraints on the pose nearest in time (within max_time_difference), with
// information I / sigma^2. Latitude/longitude go through GeographicLib's
// LocalCartesian (WGS84 -> local ENU) around ONE origin for the whole job,
// the first fix read, so the numbers stay small and all runs share the frame.
//
// Unknown correspondences. A run with ids: false has its landmark ids
// dropped: every observation gets a feature of its own; such features and
// those read without an id (core::kNoFeatureId) are never merged by id and
// get fresh ids above every other feature id (so they survive the native
// logs of .job/), for the associate stage to tie.
//
// MRCLAM. Every robot starts at the origin of its own frame (never at its
// Vicon pose: nothing may give the runs their relative placement); its
// ground truth is kept for the report only. Barcodes in no row of
// Barcodes.dat are skipped and counted per run. Robots of the same dataset
// folder drove at the same time: a measurement of another robot's barcode
// becomes a robot-to-robot constraint (tools/job/robot_sightings.h).
//
// Components. Runs are joined (union-find) when they share a feature id, when
// a robot sighting ties them, and all runs with GPS are joined (GPS is one
// global frame). Each component is
// solved on its own: a run tied to nothing is its own component, reported as
// such and never silently merged into another's frame. Gauge: a component
// with GPS has no fixed pose; one without fixes the first pose of its first
// run (every input FIX is cleared: each run's fix is in its own frame).
//
// THREAD SAFETY: reentrant. ALLOCATION: O(problem).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/information_repair.h"
#include "core/problem.h"
#include "core/status.h"
#include "tools/job/job_spec.h"
#include "tools/job/robot_sightings.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools::job {

struct RunInfo {
  std::string name;
  int32_t first_pose = 0;  // in the merged problem
  int32_t num_poses = 0;
  int32_t component = 0;
  int64_t gps_fixes = 0;
  bool has_ground_truth = false;
  // No time stamps of its own (g2o, iSAM) or the simulator's, which start at
  // 0 in every run: its TUM files get a synthetic clock (job_export.h).
  bool synthetic_time = false;
  // solver.repair_information: information matrices repaired, first lines.
  core::InformationRepairs information_repairs;
  // Came with unknown correspondences (ids: false, or observations without a
  // feature id): the associate stage runs data association.
  bool unidentified = false;
  // Poses whose true position lies in the run's GPS-denied region (simulate).
  std::vector<uint8_t> indoor;  // one per pose of the run, or empty
  // MRCLAM: measurements with a barcode in no row of Barcodes.dat (skipped),
  // and the first of them as "file:line: text".
  int64_t unknown_barcodes_skipped = 0;
  std::vector<std::string> unknown_barcode_lines;
};

struct JobData {
  core::Problem2d problem;
  std::vector<RunInfo> runs;
  int32_t num_components = 0;
  // Ground truth, when known: per run a TUM-like list; features by id.
  std::map<std::string, std::vector<StampedPose2>> ground_truth;
  std::map<int64_t, core::Point2> ground_truth_features;
  std::optional<std::array<double, 3>> enu_origin;  // lat, lon, height of the GPS frame
  // Robot sightings read (tools/job/robot_sightings.h): how many became
  // constraints (problem.pose_range_bearings) and how many were dropped.
  SightingCounts sightings;
};

// Reads / simulates every run of `job`, attaches GPS, merges, and finds the
// components (setting the gauge as above). Errors name the run's input file
// and line, or the job file's line for the run.
StatusOr<JobData> LoadJobData(const JobSpec& job);

// The sub-problem of component `c`: its poses (merged order), the features its
// observations reference, and the constraints among them. `pose_map` and
// `feature_map` receive the merged index of every sub-problem pose / feature.
core::Problem2d ExtractComponent(const JobData& data, int32_t component,
                                 std::vector<int32_t>* pose_map,
                                 std::vector<int32_t>* feature_map);

// Brings every run of component `c` into one frame before the solve: each
// run's guesses are in its own frame. `sub` is ExtractComponent's result after
// core::InitializeProblem (features placed from their first sight). Runs are
// visited in order; a run with >= 2 GPS fixes is moved onto its fixes, else a
// later run with >= 2 landmarks first seen by earlier runs is moved onto
// those and onto the robot sightings between it and earlier runs: the rigid T
// minimizing sum |T p_own - p_ref|^2 (Umeyama), with p_own the landmark's
// first-sight position from this run's own poses, and for a sighting the
// observed robot's position (this run's pose, or the point the range-bearing
// puts it at from this run's observing pose) against the same point from the
// earlier run. T is applied to the run's poses and to the landmarks it saw
// first. Returns the number of runs moved.
int AlignRunFrames(const JobData& data, int32_t component, core::Problem2d* sub);

// Copies the sub-problem's pose and feature values back into `problem`.
void ScatterComponent(const core::Problem2d& sub, const std::vector<int32_t>& pose_map,
                      const std::vector<int32_t>& feature_map, core::Problem2d* problem);

// The poses of one run as a problem of their own (for the TUM writer).
core::Problem2d RunTrajectory(const core::Problem2d& problem, const RunInfo& run);

// Recomputes the components and the gauge (as LoadJobData does) after the
// features changed, e.g. after data association tied runs together.
void UpdateComponents(JobData* data);

// Removes every GPS constraint and re-applies the no-GPS gauge (first pose of
// each component's first run fixed): the ablation of the Figure 6 comparison.
void RemoveGps(JobData* data);

}  // namespace graphslam::tools::job
