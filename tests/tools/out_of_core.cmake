# Out of core: ingest, --workdir, streaming mode, kill -9 during ingest.
graphslam_test(tools/out_of_core)
add_dependencies(out_of_core_test graphslam)
graphslam_test(tools/streaming_campus_simulator)
graphslam_test(tools/ingest_kill)
add_dependencies(ingest_kill_test graphslam)
graphslam_test(tools/out_of_core_solve)
graphslam_test(tools/streaming_initialization)
add_dependencies(streaming_initialization_test graphslam)
