# Tests of the 3-D importers and exporters.
graphslam_test(storage/g2o_3d_reader)
graphslam_test(storage/isam_3d_reader)
graphslam_test(storage/solver_checkpoint)
graphslam_test(storage/candidate_file)
graphslam_test(storage/feature_id_file)
