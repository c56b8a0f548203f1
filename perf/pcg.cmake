# Issue 4: the reduced-system solver configurations side by side.
add_executable(pcg_configurations pcg_configurations.cc)
target_link_libraries(pcg_configurations PRIVATE
  graphslam_partition graphslam_storage graphslam_core graphslam_warnings)
