# 3-D map fusion throughput (docs/benchmarks.md, "Map fusion").
add_executable(map_fusion_perf map_fusion_perf.cc)
target_link_libraries(map_fusion_perf PRIVATE graphslam_tools TBB::tbb graphslam_warnings)
