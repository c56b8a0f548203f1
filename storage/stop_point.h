// StopPointForTests: a fault-injection point for kill -9 tests.
//
// When the environment variable GRAPHSLAM_STOP_AT equals `point`, the process
// stops itself (SIGSTOP) right there. A test that started it waits for the
// stop (waitpid with WUNTRACED), then sends SIGKILL: the process dies at
// exactly that point, whatever the machine's speed or load, and a test never
// has to guess when to kill. Unset (always, outside tests), it is one getenv.
//
// Points (docs/guarantees.md lists them):
//   "solver_checkpoint N"   after the checkpoint of iteration N is durable
//                           (0: the initialized start)
//   "job_stage_start S"     after a job logged the start of stage S
//   "job_stage_done S"      after a job recorded stage S as completed
//   "map_batch N"           after the N-th batch of scans was fused
//   "associate_exchanged"   after `solve STORE --associate` put the rewritten
//                           store in place
//   "ingest_index_on_disk"  after an ingest wrote its FeatureIndex to
//                           work/pass1.bin, before the initialization (no
//                           progress record yet: a resume starts afresh)
//   "ingest_pass1"          after an ingest recorded its first pass
//   "ingest_spill N"        after the N-th spill of the observation buffer
//   "ingest_chunks N"       after chunks [0, k) with k >= N are durable and
//                           recorded in the ingest's progress
//   "ingest_scan_chunks N"  after k >= N scan chunks are durable and recorded
//
// The counted points (StopPointAtCountForTests) stop at the first count that
// reaches N: chunks become durable in parallel groups, so an exact count may
// never be reported.
//   "rank R solver_checkpoint N"  under mpirun, rank R, after every rank
//                           knows the checkpoint of iteration N is durable
//
// A test that did not start the stopping process itself (mpirun starts the
// ranks) sets GRAPHSLAM_STOP_PID_FILE too: the process writes its pid there
// (atomically: a temporary file renamed) before it stops.
//
// THREAD SAFETY: safe from any thread (getenv, raise). ALLOCATION: none
// (the pid file: one short string).
#pragma once

#include <string_view>

namespace graphslam::storage {

inline constexpr const char* kStopPointVariable = "GRAPHSLAM_STOP_AT";
inline constexpr const char* kStopPidFileVariable = "GRAPHSLAM_STOP_PID_FILE";

void StopPointForTests(std::string_view point);

// Stops when GRAPHSLAM_STOP_AT is "`name` N" and `count` >= N.
void StopPointAtCountForTests(std::string_view name, long long count);

}  // namespace graphslam::storage
