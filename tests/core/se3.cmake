# Tests of the 3-D (SE(3)) math, models and solver.
graphslam_test(core/se3_models)
graphslam_test(core/graphslam_solver_3d)
graphslam_test(core/chunk_passes_3d)
