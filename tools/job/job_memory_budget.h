// The memory budget of a batch job (`graphslam run`, the job file's
// memory_limit): what its stages hold at their peak, and the smallest limit
// that holds every one of them. A job keeps its merged problem in memory from
// the ingest to the export (P poses, F features, O observations of all runs),
// so for the stages other than the map
//   core = base + P pose + O observation + F feature
// (the problem, a component's copy, its in-memory chunks, the solver's
// reduced system and the checkpoints; a CHOLMOD factor comes on top: below),
// its P, F, O terms twice with compare_without_gps (two problems at once).
// The map stage holds the problem too, plus the fusion's tiles, one batch of
// points and the scan chunks (tools/job/job_map.h):
//   map   = core + map_fixed + batch_points * map_batch_point + tiles
// where batch_points = clamp(limit / 2048, 20 000, 2 000 000), fewer if the
// tiles would get less than kJobMinTileBytes, and tiles is what the limit
// leaves (a map larger than its tiles spills them to disk and is written as
// tiles). So
//   associate = core + F associate_feature   (unknown correspondences)
//   need  = max(core, map at tiles = kJobMinTileBytes, associate)
// (map: runs with scans; associate: the associate stage on runs with
// `ids: false`, whose every observation starts as a feature of its own)
// A limit below the need is refused before the job writes anything (exit 2),
// naming the need and its parts. Above it, the solver's CHOLMOD factor gets
// what the limit leaves above core (spare_bytes): `linear_solver: auto`
// takes CHOLMOD only if kCholmodBytesPerFactorByte x 8 lnz fits in it
// (PCG otherwise); `linear_solver: cholmod` stops after CHOLMOD's symbolic
// analysis when it does not (CheckJobCholmodFactor), naming the limit that
// would hold it. The export's report picture reads every point of the map's
// .pcd files (tools/job/map_image.h, ~kJobMapPictureBytesPerPoint each): it is
// left out, with a warning, when they do not fit in spare_bytes either.
//
// The constants were measured with /usr/bin/time -v (peak RSS) on simulated
// campus jobs of 600 to 16 000 poses and 95 to 20 000 features (docs/jobs.md,
// "Memory limit"); the per-pose term covers the incremental initialization's
// stages and the CHOLMOD factor of those campuses.
//
// THREAD SAFETY: pure functions.
#pragma once

#include <cstdint>

#include "core/problem.h"
#include "core/status.h"
#include "tools/job/job_spec.h"

namespace graphslam::tools::job {

inline constexpr int64_t kJobBaseBytes = int64_t{32} << 20;
inline constexpr int64_t kJobBytesPerPose = 7 << 10;
inline constexpr int64_t kJobBytesPerObservation = 600;
inline constexpr int64_t kJobBytesPerFeature = 256;
// The map stage beyond the problem: the OctoMap fusion's working set, the
// scan chunk being read (at most 16 MiB / 64 of the limit), the point cloud
// writer; per point of a batch: the point, its ray and the voxel cloud's cell.
inline constexpr int64_t kJobMapFixedBytes = int64_t{8} << 20;
inline constexpr int64_t kJobMapBytesPerBatchPoint = 64;
inline constexpr int64_t kJobMinTileBytes = int64_t{16} << 20;
// Data association (partition/association/association_driver.h): its rounds'
// candidate pairs, merges and solves; 8.2 and 9.6 KiB per feature measured at
// 3 507 and 10 709 features (it grows a little faster than linearly).
inline constexpr int64_t kJobAssociateBytesPerFeature = 16 << 10;
// The point (12 B), its intensity and run (8 B), the file's bytes and the
// decoder's copy.
inline constexpr int64_t kJobMapPictureBytesPerPoint = 64;

struct JobSize {
  int64_t poses = 0;
  int64_t features = 0;
  int64_t observations = 0;
  bool map = false;  // the map stage fuses scans
  // compare_without_gps: the optimize stage holds a second problem, solved
  // without GPS, beside the first.
  bool second_problem = false;
  // The associate stage runs data association over these features (runs
  // with `ids: false`).
  bool associate = false;
};

struct JobBudget {
  int64_t need_bytes = 0;        // the smallest limit that works
  int64_t core_bytes = 0;        // every stage but the map's
  // What the limit leaves beside core: the optimize stage's CHOLMOD factor
  // (with its indices, S, workspace), the export's map picture.
  int64_t spare_bytes = 0;
  int64_t map_tile_bytes = 0;    // the fusion's tile budget (map stage)
  int64_t map_batch_points = 0;  // points per fusion batch (map stage)
};

// The size of `job` with its merged `problem` (map: the map stage is chosen
// and a run has scans: a scan store, simulated scans, a native log's SCAN
// records; associate: the associate stage is chosen and a run has
// `ids: false`).
JobSize JobSizeOf(const JobSpec& job, const core::Problem2d& problem);

// The budget of a job of `size` under `limit_bytes` (> 0). InvalidArgument
// naming the limit, the need, its parts and the job's size when the limit is
// below the need.
StatusOr<JobBudget> BudgetJob(int64_t limit_bytes, const JobSize& size);

// `linear_solver: cholmod` under `limit_bytes`, once CHOLMOD's analysis gave
// the factor's values (8 lnz, `factor_bytes`): OK if
// kCholmodBytesPerFactorByte times that fits in BudgetJob's spare_bytes;
// else InvalidArgument naming the smallest limit that holds it.
Status CheckJobCholmodFactor(int64_t limit_bytes, const JobSize& size, double factor_bytes);

}  // namespace graphslam::tools::job
