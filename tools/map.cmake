# 3-D maps (issue 5): `graphslam map`, the map builder (scans x optimized
# poses -> .bt and .pcd) and `simulate --3d --scans` (the 3-D campus).
target_sources(graphslam_tools PRIVATE
  campus_3d.cc
  map_builder.cc
  map_command.cc
  simulate_3d_command.cc)
