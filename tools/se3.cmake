# The 3-D branch of `graphslam solve`.
target_sources(graphslam_tools PRIVATE solve_3d_command.cc)
target_sources(graphslam_tools PRIVATE solve_report.cc)
