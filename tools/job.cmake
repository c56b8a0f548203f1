# Batch jobs: `graphslam run JOB.yaml` (issue 7, docs/jobs.md).
target_sources(graphslam_tools PRIVATE
  run_command.cc
  job/job_data.cc
  job/job_export.cc
  job/job_map.cc
  job/job_runner.cc
  job/job_spec.cc
  job/job_state.cc
  job/plots.cc
  job/report_html.cc
  job/robot_sightings.cc
  job/simulated_scans.cc)
target_link_libraries(graphslam_tools PRIVATE
  yaml-cpp ${GeographicLib_LIBRARIES} PkgConfig::PLPLOT)
