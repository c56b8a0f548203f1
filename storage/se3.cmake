# 3-D (SE(3)) importers and exporters.
target_sources(graphslam_storage PRIVATE
  dimension_detection.cc
  g2o_3d_reader.cc
  g2o_3d_writer.cc
  isam_3d_reader.cc)
