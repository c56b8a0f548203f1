# Measurement and motion models (core/*_model.h).
target_sources(graphslam_core PRIVATE)
