# Batch jobs: `graphslam run JOB.yaml` (issue 7, docs/jobs.md).
target_sources(graphslam_tools PRIVATE
  run_command.cc
  job/job_data.cc
  job/job_export.cc
  job/job_map.cc
  job/job_memory_budget.cc
  job/job_runner.cc
  job/job_spec.cc
  job/job_state.cc
  job/constraint_residuals.cc
  job/map_image.cc
  job/report_figures.cc
  job/report_html.cc
  job/report_inputs.cc
  job/robot_sightings.cc
  job/simulated_scans.cc
  job/svg_figure.cc)
find_package(ZLIB REQUIRED)  # the report's map picture (PNG)
target_link_libraries(graphslam_tools PRIVATE
  yaml-cpp ${GeographicLib_LIBRARIES} ZLIB::ZLIB)
