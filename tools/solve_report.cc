#include "tools/solve_report.h"

#include <tbb/info.h>

#include <cstdio>

#include "tools/resource_usage.h"

namespace graphslam::tools {

nlohmann::json SolverReport(const SolveCommandOptions& options, const core::SolverSummary& summary,
                            const char* format_name, double total_seconds) {
  nlohmann::json report;
  report["input"] = options.input;
  report["format"] = format_name;
  report["solver"] = core::LinearSolverName(summary.linear_solver_used);
  report["preconditioner"] = options.preconditioner;
  report["pcg_eta_min"] = options.pcg_eta_min;
  report["pcg_eta_max"] = options.pcg_eta_max;
  report["pcg_deflation"] = options.pcg_deflation;
  report["pcg_truncation"] = options.pcg_truncation;
  report["initial_chi2"] = summary.initial_chi2;
  report["final_chi2"] = summary.final_chi2;
  report["iterations"] = summary.iterations;
  report["converged"] = summary.converged;
  report["termination"] = summary.termination;
  report["observations_used"] = summary.observations_used;
  report["eliminated_features"] = summary.eliminated_features;
  report["kept_features"] = summary.kept_features;
  report["robust_kernel"] = options.robust_kernel;
  report["initialization"] = options.initialization;
  report["resumed_from_iteration"] = summary.resumed_from_iteration;
  report["excluded_features"] = summary.excluded_features;
  report["unobserved_features"] = summary.unobserved_features;
  report["reduced_nonzero_blocks"] = summary.reduced_nonzero_blocks;
  report["threads"] = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
  report["seconds"] = total_seconds;
  report["peak_rss_bytes"] = PeakRssBytes();
  nlohmann::json per_iteration = nlohmann::json::array();
  for (const core::IterationSummary& it : summary.per_iteration) {
    per_iteration.push_back({{"iteration", it.iteration},
                             {"chi2", it.chi2},
                             {"candidate_chi2", it.candidate_chi2},
                             {"step_norm", it.step_norm},
                             {"gradient_max_norm", it.gradient_max_norm},
                             {"linear_solver_iterations", it.linear_iterations},
                             {"lambda", it.lambda},
                             {"relative_decrease", it.relative_decrease},
                             {"accepted", it.accepted},
                             {"seconds", it.seconds},
                             {"reduce_seconds", it.reduce_seconds},
                             {"solve_seconds", it.solve_seconds},
                             {"recover_seconds", it.recover_seconds},
                             {"chunk_passes", it.chunk_passes}});
  }
  report["per_iteration"] = per_iteration;
  return report;
}

void PrintSolverSummaryLines(std::FILE* out, const core::SolverSummary& summary,
                             double total_seconds) {
  std::fprintf(out, "  linear solver      %s\n", core::LinearSolverName(summary.linear_solver_used));
  std::fprintf(out, "  initial chi2       %.9g (where the solve started, after initialization)\n",
               summary.initial_chi2);
  std::fprintf(out, "  final chi2         %.9g\n", summary.final_chi2);
  std::fprintf(out, "  iterations         %d (%s)\n", summary.iterations, summary.termination.c_str());
  std::fprintf(out, "  seconds            %.3f\n", total_seconds);
  std::fprintf(out, "  peak RSS           %.1f MiB\n", PeakRssBytes() / (1024.0 * 1024.0));
}

nlohmann::json InformationRepairsReport(const core::InformationRepairs& repairs) {
  return {{"repaired", repairs.count},
          {"first_lines", repairs.first_lines},
          {"eigenvalue_floor_relative", core::kInformationEigenvalueFloor}};
}

void PrintInformationRepairs(std::FILE* out, const core::InformationRepairs& repairs) {
  std::fprintf(out, "  information        %lld matrices were not positive definite: repaired\n",
               static_cast<long long>(repairs.count));
}

}  // namespace graphslam::tools
