# Scans on disk, 3DTK scan folders and PCD files (issue 5, docs/maps.md).
target_sources(graphslam_storage PRIVATE
  internal/pcl_module_loader.cc
  pcd_io.cc
  scan_store.cc
  threedtk_reader.cc
  tiled_voxel_cloud.cc)
# Every call into PCL lives in the module libgraphslam_pcl, loaded on the
# first .pcd operation (storage/internal/pcl_module_api.h): linking PCL here
# would load VTK and ~60 other libraries at every start of every program.
add_library(graphslam_pcl MODULE pcl_module.cc)
target_include_directories(graphslam_pcl PRIVATE ${PROJECT_SOURCE_DIR})
target_include_directories(graphslam_pcl SYSTEM PRIVATE ${PCL_INCLUDE_DIRS})
target_link_libraries(graphslam_pcl PRIVATE ${PCL_LIBRARIES} graphslam_warnings)
set_target_properties(graphslam_pcl PROPERTIES CXX_VISIBILITY_PRESET hidden)
add_dependencies(graphslam_storage graphslam_pcl)
set(GRAPHSLAM_PCL_MODULE_DIR "${CMAKE_INSTALL_LIBDIR}/graphslam")
set_source_files_properties(internal/pcl_module_loader.cc PROPERTIES COMPILE_DEFINITIONS
  "GRAPHSLAM_PCL_MODULE_BUILD_PATH=\"$<TARGET_FILE:graphslam_pcl>\";GRAPHSLAM_PCL_MODULE_INSTALL_PATH=\"${CMAKE_INSTALL_PREFIX}/${GRAPHSLAM_PCL_MODULE_DIR}/$<TARGET_FILE_NAME:graphslam_pcl>\"")
target_link_libraries(graphslam_storage PRIVATE ${CMAKE_DL_LIBS})
# SCAN records of native logs: .pcd files per pose (docs/formats/native_log.md).
target_sources(graphslam_storage PRIVATE native_log_scans.cc)
