# 3-D (SE(3)) problems: initialization and the Levenberg-Marquardt driver.
target_sources(graphslam_core PRIVATE
  graphslam_solver_3d.cc
  pose_factors_3d.cc
  initialization_3d.cc)
