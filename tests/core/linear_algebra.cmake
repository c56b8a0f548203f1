# Tests of the linear algebra.
graphslam_test(core/block_sparse_matrix)
graphslam_test(core/schur_eliminator)
graphslam_test(core/slot_map)
graphslam_test(core/preconditioned_conjugate_gradient)
graphslam_test(core/block_jacobi_preconditioner)
graphslam_test(core/cholmod_solver)
graphslam_test(core/serial_openmp)
graphslam_test(core/incomplete_cholesky_preconditioner)
