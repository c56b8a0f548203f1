# The scaling benchmark's plot (perf/scaling_benchmark.sh, docs/benchmarks.md).
add_executable(scaling_plot scaling_plot.cc)
target_link_libraries(scaling_plot PRIVATE PkgConfig::PLPLOT)
