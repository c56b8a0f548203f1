# Out of core (issue 3): external bucketing and the bounded-memory ingest.
target_sources(graphslam_partition PRIVATE
  external_bucketing.cc
  streaming_ingest.cc
  pose_graph_initialization.cc)
