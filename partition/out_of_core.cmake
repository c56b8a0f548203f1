# Out of core (issue 3): external bucketing and the bounded-memory ingest.
target_sources(graphslam_partition PRIVATE
  external_bucketing.cc
  spill_frames.cc
  replay_frames.cc
  first_sight_initialization.cc
  ingest_progress.cc
  ingest_scans.cc
  streaming_ingest.cc
  pose_graph_initialization.cc)
target_link_libraries(graphslam_partition PRIVATE nlohmann_json::nlohmann_json)
target_link_libraries(graphslam_partition PRIVATE graphslam::zstd)
