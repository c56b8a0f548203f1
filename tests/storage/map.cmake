# Tests of the 3-D map's storage (issue 5): scans on disk, 3DTK, PCD.
foreach(_map_test threedtk_reader pcd_io scan_store)
  graphslam_test(storage/${_map_test})
endforeach()
# The PCD test reads back with PCL's own reader directly.
target_include_directories(pcd_io_test SYSTEM PRIVATE ${PCL_INCLUDE_DIRS})
target_link_libraries(pcd_io_test PRIVATE ${PCL_LIBRARIES})
