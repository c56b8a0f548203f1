# Tests of the 3-D map's storage (issue 5): scans on disk, 3DTK, PCD.
foreach(_map_test threedtk_reader pcd_io scan_store)
  graphslam_test(storage/${_map_test})
endforeach()
# The PCD test reads back with PCL's own reader directly.
graphslam_test_with_pcl(pcd_io_test)
# The registered cloud downsampled within a memory budget, read back by PCL.
graphslam_test(storage/tiled_voxel_cloud)
graphslam_test_with_pcl(tiled_voxel_cloud_test)
