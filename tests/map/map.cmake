# Tests of the 3-D map (issue 5): scans on disk, 3DTK, PCD, OctoMap fusion.
foreach(_map_test tiled_fusion threedtk_reader pcd_io scan_store)
  graphslam_test(map/${_map_test})
  target_link_libraries(${_map_test}_test PRIVATE graphslam_map)
endforeach()
# The PCD test reads back with PCL's own reader directly.
target_include_directories(pcd_io_test SYSTEM PRIVATE ${PCL_INCLUDE_DIRS})
target_link_libraries(pcd_io_test PRIVATE ${PCL_LIBRARIES})
