graphslam_test(core/chunk_passes)
graphslam_test(core/graphslam_solver)
