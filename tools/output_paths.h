// CheckOutputPaths: before a command reads or solves anything, every output
// it was asked for must be writable where it was asked to go, so that a
// missing folder is found at once, not after hours of work (issue 22, a
// `--report /nodir/x.json` found only after the solve).
//
//   file output     its parent folder exists, is a folder, and the process
//                   may create files in it (access W_OK | X_OK); the path
//                   itself is not an existing folder. "-" (stdout) and ""
//                   (not asked for) pass.
//   folder output   if it exists it is a folder the process may write; if
//                   not, its nearest existing ancestor is (it will be created
//                   with its parents).
//
// A file output's temporaries that a killed earlier run left next to it are
// removed here once proved abandoned (storage/abandoned_temporaries.h).
//
// Failures are IOError (exit 3, tools/exit_codes.h) naming the option and the
// path: "--report /nodir/x.json: the folder /nodir does not exist; expected an
// existing folder to write the output into". The check is advisory as any
// check before a write is (the folder can vanish later); the writes still
// report their own errors.
//
// THREAD SAFETY: reentrant. ALLOCATION: the path strings.
#pragma once

#include <string>
#include <vector>

#include "core/status.h"

namespace graphslam::tools {

struct OutputPath {
  std::string option;  // "--report", "-o", ... (for the message)
  std::string path;    // "" when not asked for
  bool folder = false;
};

Status CheckOutputPaths(const std::vector<OutputPath>& outputs);

}  // namespace graphslam::tools
