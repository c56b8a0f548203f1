// The scans and the map stage of a job (docs/jobs.md, "Scans and the map").
//
// Ingest (WriteSimulatedScans): every simulate run with `scans: true` gets a
// scan per true pose (tools/job/simulated_scans.h) written to a disk-backed
// scan store, OUTPUT/.job/scans/<run>/scans/ (storage/scan_store.h), in chunks
// of at most ScanChunkBytes(memory_limit): scans never sit in memory.
//
// Map (BuildJobMap): every run's scans, each moved by its OPTIMIZED pose
// (a 2-D pose lifted to (x, y, sensor_height, yaw)), fused in scan order by
// the tiled parallel OctoMap fusion (partition/fusion/tiled_fusion.h through
// tools/map_builder.h) into OUTPUT/.job/map.bt and a voxel-downsampled
// binary_compressed OUTPUT/.job/map.pcd with the run id of every point
// (storage/pcd_io.h). The map is a deterministic function of the optimized
// poses and the scans, so a stage interrupted by kill -9 restarts from its
// beginning and writes the same bytes. Memory: the fusion's tiles are kept
// within half the job's memory_limit (spilled to OUTPUT/.job/map.spill
// beyond; when the whole tree exceeds that budget the map is written as
// tiles, OUTPUT/.job/map.tiles/), and a batch holds about
// memory_limit / 2048 points. The export stage copies the files, atomically,
// to OUTPUT/map.bt and OUTPUT/map.pcd (or OUTPUT/map.tiles/).
//
// THREAD SAFETY: one job per process. ALLOCATION: the map, one scan chunk,
// one batch of rays.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "core/status.h"
#include "tools/job/job_data.h"
#include "tools/job/job_spec.h"
#include "tools/progress_display.h"

namespace graphslam::tools::job {

// Target bytes of one scan chunk: memory_limit / 64 within [256 KiB, 16 MiB]
// (16 MiB without a limit).
int64_t ScanChunkBytes(int64_t memory_limit);

// Writes the scans of every simulate run with scans: true into
// `work`/scans/<run name>/, and copies those of every native log run (without
// a scans: folder) whose SCAN records name .pcd files (read by PCL, one scan
// at a time; storage/native_log_scans.h), so the map stage needs neither the
// log nor the .pcd files. Returns the number of scans written.
[[nodiscard]] StatusOr<int64_t> WriteSimulatedScans(const JobSpec& spec, const JobData& data,
                                                    const std::string& work);

// True if any run has scans (simulated or a scan folder), or, given the
// job's `work` folder, a native log run whose SCAN records were copied there.
bool JobHasScans(const JobSpec& spec, const std::string& work = "");

// Builds `work`/map.bt and `work`/map.pcd from the scans and the optimized
// `data` (see above); returns the summary that goes into the report (also
// written to `work`/map.json). `display` may be null.
[[nodiscard]] StatusOr<nlohmann::json> BuildJobMap(const JobSpec& spec, const JobData& data,
                                                   const std::string& work,
                                                   ProgressDisplay* display);

// Copies the map files of `work` (as listed in map.json) into `output`, each
// atomically; returns the output names written.
[[nodiscard]] StatusOr<std::vector<std::string>> ExportJobMap(const std::string& work,
                                                              const std::string& output);

}  // namespace graphslam::tools::job
