# Scans on disk, 3DTK scan folders and PCD files (issue 5, docs/maps.md).
# PCL is private and only pcd_io.cc includes it.
target_sources(graphslam_storage PRIVATE
  pcd_io.cc
  scan_store.cc
  threedtk_reader.cc
  tiled_voxel_cloud.cc)
target_include_directories(graphslam_storage SYSTEM PRIVATE ${PCL_INCLUDE_DIRS})
target_link_libraries(graphslam_storage PRIVATE ${PCL_LIBRARIES})
# SCAN records of native logs: .pcd files per pose (docs/formats/native_log.md).
target_sources(graphslam_storage PRIVATE native_log_scans.cc)
