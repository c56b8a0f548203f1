# Spatial tiles of the 3-D map fused into OctoMap in parallel within a memory
# budget (issue 5, docs/maps.md). OctoMap is public: tests compare trees.
target_sources(graphslam_partition PRIVATE tiled_fusion.cc)
target_include_directories(graphslam_partition SYSTEM PUBLIC ${OCTOMAP_INCLUDE_DIRS})
target_link_libraries(graphslam_partition PUBLIC ${OCTOMAP_LIBRARIES} TBB::tbb)
