# 3-D maps (issue 5): `graphslam map` and `simulate --3d --scans`.
target_sources(graphslam_tools PRIVATE
  map_command.cc
  simulate3d_command.cc)
target_link_libraries(graphslam_tools PUBLIC graphslam_map)
