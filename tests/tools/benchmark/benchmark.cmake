# `graphslam benchmark` (tools/benchmark).
graphslam_test(tools/benchmark/power_law_fit)
graphslam_test(tools/benchmark/benchmark_command)
add_dependencies(benchmark_command_test graphslam)
