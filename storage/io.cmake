# Importers, exporters, files.
target_sources(graphslam_storage PRIVATE
  abandoned_temporaries.cc
  atomic_file.cc
  env.cc
  stop_point.cc
  format_detection.cc
  features_csv_writer.cc
  g2o_reader.cc
  g2o_writer.cc
  internal/problem_validation.cc
  compressed_file.cc
  internal/text_blocks.cc
  internal/text_reader.cc
  isam_reader.cc
  mrclam_reader.cc
  native_log_reader.cc
  native_log_counts.cc
  tum_writer.cc)
# Observation chunk files (docs/formats/observation_chunk.md).
target_sources(graphslam_storage PRIVATE
  chunk_reader.cc
  chunk_writer.cc
  crc32c.cc)
target_sources(graphslam_storage PRIVATE chunk_store.cc chunk_store_writer.cc)
# Locks, ownership and checksums of stores and job folders (docs/guarantees.md).
target_sources(graphslam_storage PRIVATE checksummed_json.cc directory_lock.cc file_checksum.cc
  store_directory.cc)
target_sources(graphslam_storage PRIVATE solver_checkpoint.cc sealed_json_text.cc feature_record_file.cc candidate_file.cc
  solver_state_file.cc feature_id_file.cc)
# TORO / GTSAM .graph files, 2-D and 3-D (docs/formats/toro_graph.md).
target_sources(graphslam_storage PRIVATE toro_reader.cc)
# Trajectory files as ground truth: TUM and KITTI odometry poses (issue 23).
target_sources(graphslam_storage PRIVATE tum_reader.cc kitti_pose_reader.cc trajectory_format.cc)
# The run name table beside a job's map.pcd (issue 23).
target_sources(graphslam_storage PRIVATE pcd_run_names.cc)
