# Tests of the models.
graphslam_test(core/bearing_model)
graphslam_test(core/gps_model)
graphslam_test(core/initialization)
graphslam_test(core/point_observation_model)
graphslam_test(core/pose_range_bearing_model)
graphslam_test(core/range_bearing_model)
graphslam_test(core/relative_pose_model)
graphslam_test(core/velocity_motion_model)
