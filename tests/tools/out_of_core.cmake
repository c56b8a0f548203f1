# Out of core: ingest, --workdir, streaming mode, kill -9 during ingest.
graphslam_test(tools/out_of_core)
add_dependencies(out_of_core_test graphslam)
graphslam_test(tools/streaming_campus_simulator)
graphslam_test(tools/ingest_kill)
add_dependencies(ingest_kill_test graphslam)
graphslam_test(tools/out_of_core_solve)
graphslam_test(tools/memory_budget)
add_dependencies(memory_budget_test graphslam)
graphslam_test(tools/streaming_initialization)
add_dependencies(streaming_initialization_test graphslam)
# kill -9 during an ingest that copies .pcd scans into STORE/scans/, then --resume.
graphslam_test(tools/ingest_scans_kill)
add_dependencies(ingest_scans_kill_test graphslam)
graphslam_test_with_pcl(ingest_scans_kill_test)
# Issue 22: locks, integrity, foreign folders, stale inputs and temporaries,
# adversarially, against the binary.
graphslam_test(tools/adversarial_store)
add_dependencies(adversarial_store_test graphslam)
