# graphslam_ceres_peer_3d: 3-D g2o graphs solved by Ceres (the converged peer
# of the SE-Sync 3-D benchmarks, docs/benchmarks.md). Needs Ceres, found by
# perf/CMakeLists.txt.
if(Ceres_FOUND)
  add_executable(graphslam_ceres_peer_3d ceres_peer/ceres_peer_3d_main.cc)
  target_link_libraries(graphslam_ceres_peer_3d PRIVATE
    graphslam_tools graphslam_storage graphslam_core Ceres::ceres CLI11::CLI11
    nlohmann_json::nlohmann_json graphslam_warnings)
endif()
