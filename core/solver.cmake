# Linearization, reduce pass, initialization, Levenberg-Marquardt driver.
target_sources(graphslam_core PRIVATE
  anderson_acceleration.cc
  chunk_passes.cc
  internal/chunk_pass_kernels.cc
  internal/chunked_solve.cc
  feature_linearizer.cc
  graphslam_solver.cc
  pose_factors.cc
  robust_kernel.cc)
