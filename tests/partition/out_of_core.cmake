graphslam_test(partition/external_bucketing)
graphslam_test(partition/spill_frames)
graphslam_test(partition/replay_frames)
graphslam_test(partition/first_sight_initialization)
# The ingest copies a native log's .pcd scans into STORE/scans/ (PCL writes them in the test).
graphslam_test(partition/ingest_scans)
target_include_directories(ingest_scans_test SYSTEM PRIVATE ${PCL_INCLUDE_DIRS})
target_link_libraries(ingest_scans_test PRIVATE ${PCL_LIBRARIES})
# The ingest's progress record: checksum and input identity (issue 22).
graphslam_test(partition/ingest_progress)
