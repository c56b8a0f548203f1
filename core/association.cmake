# Data association math (issue 6): the correspondence test (Table 9) and
# selected blocks of the pose covariance.
target_sources(graphslam_core PRIVATE
  correspondence_test.cc
  pose_marginals.cc)
