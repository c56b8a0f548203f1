# Tests of the 3-D map's storage (issue 5): scans on disk, 3DTK, PCD.
foreach(_map_test threedtk_reader pcd_io scan_store)
  graphslam_test(storage/${_map_test})
endforeach()
# The PCD test reads back with PCL's own reader directly.
target_include_directories(pcd_io_test SYSTEM PRIVATE ${PCL_INCLUDE_DIRS})
target_link_libraries(pcd_io_test PRIVATE ${PCL_LIBRARIES})
# The registered cloud downsampled within a memory budget, read back by PCL.
graphslam_test(storage/tiled_voxel_cloud)
target_include_directories(tiled_voxel_cloud_test SYSTEM PRIVATE ${PCL_INCLUDE_DIRS})
target_link_libraries(tiled_voxel_cloud_test PRIVATE ${PCL_LIBRARIES})
