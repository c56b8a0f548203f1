# Tests of the reduced pose system solver (issue 4).
graphslam_test(core/subgraph_preconditioner)
graphslam_test(core/reduced_system_solver)
graphslam_test(core/trajectory_deflation)
