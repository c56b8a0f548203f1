# Measurement and motion models (core/*_model.h).
target_sources(graphslam_core PRIVATE
  gps_model.cc
  initialization.cc
  interpolated_pose_range_bearing_model.cc
  point_observation_model.cc
  pose_range_bearing_model.cc
  range_bearing_model.cc
  relative_pose_model.cc
  velocity_motion_model.cc)
# Opt-in repair of non-positive-definite information matrices (issue 23).
target_sources(graphslam_core PRIVATE information_repair.cc)
