# The solve report and summary lines shared by the 2-D and 3-D steps.
target_sources(graphslam_tools PRIVATE solve_report.cc)
