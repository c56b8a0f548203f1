# `graphslam benchmark`: the scaling benchmark as a subcommand (docs/cli.md).
target_sources(graphslam_tools PRIVATE
  benchmark/benchmark_command.cc
  benchmark/child_process.cc
  benchmark/power_law_fit.cc
  benchmark/scaling_report.cc
  benchmark/scaling_sweep.cc)
