// Input format detection and the one entry point that reads any supported
// input into a core::Problem2d (ReadProblem) or core::Problem3d (ReadProblem3d).
//
//   directory containing RobotN_Odometry.dat         -> kMrclam
//   first record GRAPHSLAM_LOG                        -> kNative
//   first record VERTEX_* / EDGE_* / FIX / DATA_*     -> kG2o
//   first record ODOMETRY / EDGE2 / EDGE3 / LANDMARK / POINT3 -> kIsam
//   first record VERTEX2 / VERTEX3 / BR / EQUIV       -> kToro (TORO / GTSAM .graph)
// (a .graph file that starts with an EDGE2 or EDGE3 line reads as iSAM, whose
// EDGE2/EDGE3 carry square-root information; --format toro reads it as TORO.)
// ("first record": first line that is neither blank nor a '#' comment; only
// that line is read.) 3-D g2o/iSAM/TORO files are detected as g2o/iSAM/TORO;
// IsThreeDimensional (storage/dimension_detection.h) then sends them to
// ReadProblem3d.
//
// THREAD SAFETY: reentrant. ALLOCATION: one line.
#pragma once

#include <string>
#include <string_view>

#include "core/information_repair.h"
#include "core/problem.h"
#include "core/problem_3d.h"
#include "core/status.h"
#include "storage/mrclam_reader.h"

namespace graphslam::storage {

enum class InputFormat { kG2o, kIsam, kMrclam, kNative, kToro };

// NotFound if `path` does not exist; NotSupported naming the first token if no
// format matches; Corruption if the file has no record at all.
StatusOr<InputFormat> DetectInputFormat(const std::string& path);

// "g2o", "isam", "mrclam", "native", "toro" (the --format values besides
// "auto", which the commands resolve with DetectInputFormat); InvalidArgument
// naming every --format value, "auto" included, otherwise.
StatusOr<InputFormat> ParseInputFormat(std::string_view name);

// The name ParseInputFormat accepts for `format`.
const char* InputFormatName(InputFormat format);

// Reads `path` with the reader of `format`; `mrclam` and `mrclam_stats` (if
// given) are used for kMrclam only. `repairs` (opt-in; g2o, iSAM, native and
// TORO, whose files carry information matrices): repair non-positive-definite
// information and count it there instead of rejecting the file. (MRCLAM files
// carry none: its information comes from MrclamOptions' noise model.)
StatusOr<core::Problem2d> ReadProblem(const std::string& path, InputFormat format,
                                      const MrclamOptions& mrclam,
                                      MrclamReadStats* mrclam_stats = nullptr,
                                      core::InformationRepairs* repairs = nullptr);

// Reads a 3-D `path` with the 3-D reader of `format` (g2o, iSAM, TORO);
// NotSupported for the formats that have none (MRCLAM, native). `repairs` as
// for ReadProblem.
StatusOr<core::Problem3d> ReadProblem3d(const std::string& path, InputFormat format,
                                        core::InformationRepairs* repairs = nullptr);

}  // namespace graphslam::storage
