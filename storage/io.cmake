# Importers, exporters, files.
target_sources(graphslam_storage PRIVATE
  atomic_file.cc)
