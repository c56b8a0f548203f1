# Batch jobs (tools/job, `graphslam run`).
graphslam_test(tools/job/job_spec)
graphslam_test(tools/job/job_model_tolerance)
graphslam_test(tools/job/job_state)
graphslam_test(tools/job/report_html)
graphslam_test(tools/job/job_end_to_end)
graphslam_test(tools/job/job_resume)
graphslam_test(tools/job/job_mrclam)
graphslam_test(tools/job/job_robot_sightings)
graphslam_test(tools/job/job_gps_indoor)
graphslam_test(tools/job/job_map)
graphslam_test(tools/job/job_associate)
# The resume test runs the graphslam binary itself.
add_dependencies(job_resume_test graphslam)
graphslam_test(tools/job/job_input_checks)
# Runs from files: KITTI ground truth with times, repaired information (issue 23).
graphslam_test(tools/job/job_file_runs)
graphslam_test(tools/job/job_memory_limit)
