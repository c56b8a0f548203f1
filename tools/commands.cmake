# Further subcommands (simulate, evaluate).
target_sources(graphslam_tools PRIVATE
  campus_simulator.cc
  evaluate_command.cc
  simulate_command.cc
  trajectory_metrics.cc
  trajectory_statistics.cc)
target_sources(graphslam_tools PRIVATE ground_truth.cc)
target_sources(graphslam_tools PRIVATE ingest_command.cc)
target_sources(graphslam_tools PRIVATE out_of_core_solve.cc memory_budget.cc)
target_sources(graphslam_tools PRIVATE streaming_campus_simulator.cc)
target_sources(graphslam_tools PRIVATE association_report.cc)
target_sources(graphslam_tools PRIVATE association_store.cc)
