# Installation of the libraries for use from other CMake projects
# (docs/library.md):
#   PREFIX/include/graphslam/{core,storage,partition}/*.h  public headers
#   PREFIX/lib/libgraphslam_{core,storage,partition}.a   the libraries
#   PREFIX/lib/graphslam/libgraphslam_pcl.so              PCD files through PCL,
#       loaded by graphslam::storage on the first .pcd operation
#   PREFIX/lib/cmake/graphslam/                           graphslamConfig.cmake,
#       its version file, the exported targets graphslam::core,
#       graphslam::storage, graphslam::partition and FindCHOLMOD.cmake
# The libraries are static, so their private dependencies (CHOLMOD, spdlog,
# fmt, zstd, nlohmann-json, OctoMap, Boost's headers) are link dependencies of the
# consumer too: the config file finds them with find_dependency.
include(CMakePackageConfigHelpers)

set_target_properties(graphslam_core PROPERTIES EXPORT_NAME core)
set_target_properties(graphslam_storage PROPERTIES EXPORT_NAME storage)
set_target_properties(graphslam_partition PROPERTIES EXPORT_NAME partition)
set(GRAPHSLAM_CMAKE_DIR "${CMAKE_INSTALL_LIBDIR}/cmake/graphslam")

install(TARGETS graphslam_core graphslam_storage graphslam_partition
  EXPORT graphslamTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
# The same folder as GRAPHSLAM_PCL_MODULE_INSTALL_PATH (storage/map.cmake).
install(TARGETS graphslam_pcl LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/graphslam)
foreach(folder core storage partition)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${folder}/
    DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/graphslam/${folder}
    FILES_MATCHING PATTERN "*.h")
endforeach()
install(EXPORT graphslamTargets NAMESPACE graphslam:: DESTINATION ${GRAPHSLAM_CMAKE_DIR})

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/graphslamConfig.cmake.in
  ${CMAKE_BINARY_DIR}/graphslamConfig.cmake
  INSTALL_DESTINATION ${GRAPHSLAM_CMAKE_DIR})
# 0.x: a minor version may break the API, so only the same minor is compatible.
write_basic_package_version_file(${CMAKE_BINARY_DIR}/graphslamConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES
  ${CMAKE_BINARY_DIR}/graphslamConfig.cmake
  ${CMAKE_BINARY_DIR}/graphslamConfigVersion.cmake
  ${PROJECT_SOURCE_DIR}/cmake/FindCHOLMOD.cmake
  DESTINATION ${GRAPHSLAM_CMAKE_DIR})
