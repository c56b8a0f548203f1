# 3-D solve end to end: reference optima and ground truth (real datasets).
graphslam_test(tools/reference_optima_3d)
set_tests_properties(reference_optima_3d PROPERTIES TIMEOUT 600)
graphslam_test(tools/reference_optima_torus3d)
set_tests_properties(reference_optima_torus3d PROPERTIES TIMEOUT 600)
# 3-D checkpoints: kill -9 mid-solve, --resume, bit-identical (runs the binary).
graphslam_test(tools/solve_resume_3d)
add_dependencies(solve_resume_3d_test graphslam)
# SCAN records of native logs: .pcd scans fused by `graphslam map LOG` (runs the binary).
graphslam_test(tools/map_native_log)
add_dependencies(map_native_log_test graphslam)
