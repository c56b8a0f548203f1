graphslam_test(core/chunk_passes)
graphslam_test(core/graphslam_solver)
graphslam_test(core/robust_kernel)
graphslam_test(core/pose_factors)
