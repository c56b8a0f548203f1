// The parts of `graphslam solve`'s JSON report and terminal summary that the
// 2-D (tools/pipeline/solve_2d.cc) and the 3-D (tools/pipeline/solve_3d.cc)
// steps share: the solver's outcome, the feature partition, timings,
// resources and one entry per Levenberg-Marquardt iteration
// (docs/cli.md, "The report", lists the keys). The solve path
// (tools/pipeline/solve_path.h) adds the counts (constraints, residual
// dimension, unknowns) and stage timings for both dimensions.
//
// THREAD SAFETY: plain functions. ALLOCATION: O(iterations).
#pragma once

#include <cstdio>

#include <nlohmann/json.hpp>

#include "core/graphslam_solver.h"
#include "core/information_repair.h"
#include "tools/solve_command.h"

namespace graphslam::tools {

// input, format, solver, preconditioner, chi2s, iterations, convergence,
// observations_used, eliminated / kept / excluded / unobserved features,
// robust_kernel, initialization, resumed_from_iteration, reduced_nonzero_blocks,
// threads, seconds, peak_rss_bytes and per_iteration.
nlohmann::json SolverReport(const SolveCommandOptions& options, const core::SolverSummary& summary,
                            const char* format_name, double total_seconds);

// The terminal summary's closing lines: linear solver, chi2s, iterations,
// seconds, peak RSS.
void PrintSolverSummaryLines(std::FILE* out, const core::SolverSummary& summary,
                             double total_seconds);

// --repair-information (core/information_repair.h): the report's
// "information_repairs" object (repaired, first_lines,
// eigenvalue_floor_relative) and the summary's "information" line.
nlohmann::json InformationRepairsReport(const core::InformationRepairs& repairs);
void PrintInformationRepairs(std::FILE* out, const core::InformationRepairs& repairs);

}  // namespace graphslam::tools
