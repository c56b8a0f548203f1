# The scaling benchmark's plot (perf/scaling_benchmark.sh, docs/benchmarks.md):
# PLplot's C API (pkg-config "plplot"; the top level finds only plplot-c++).
pkg_check_modules(GRAPHSLAM_PLPLOT_C REQUIRED IMPORTED_TARGET plplot)
add_executable(scaling_plot scaling_plot.cc log_log_plot.cc)
target_link_libraries(scaling_plot PRIVATE PkgConfig::GRAPHSLAM_PLPLOT_C)
# The initialization scaling plot (perf/initialization_scaling.py).
add_executable(initialization_plot initialization_plot.cc log_log_plot.cc)
target_link_libraries(initialization_plot PRIVATE PkgConfig::GRAPHSLAM_PLPLOT_C)
target_include_directories(scaling_plot PRIVATE ${PROJECT_SOURCE_DIR})
target_include_directories(initialization_plot PRIVATE ${PROJECT_SOURCE_DIR})
