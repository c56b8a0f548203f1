# association_benchmark: data association on Victoria Park, MRCLAM and the
# simulated campus against their answer keys (docs/benchmarks.md, issue 6).
add_executable(association_benchmark association_benchmark.cc)
target_link_libraries(association_benchmark PRIVATE
  graphslam_tools graphslam_partition graphslam_storage graphslam_core graphslam_warnings)
target_compile_definitions(association_benchmark PRIVATE
  GRAPHSLAM_DATASETS_DIR="${PROJECT_SOURCE_DIR}/../shared/datasets")
