# Seed-corpus replay: every fuzz target's LLVMFuzzerTestOneInput, built with
# the regular compiler, runs over tests/fuzz/corpus/<target>/ as a CTest.
foreach(target g2o_reader isam_reader native_log_reader mrclam_reader job_spec chunk_reader
               g2o_3d_reader isam_3d_reader threedtk_reader scan_store)
  add_executable(${target}_replay fuzz/${target}_fuzzer.cc fuzz/replay_main.cc)
  target_link_libraries(${target}_replay PRIVATE
    graphslam_tools graphslam_storage graphslam_core graphslam_testing graphslam_warnings)
  add_test(NAME fuzz_replay_${target}
           COMMAND ${target}_replay ${PROJECT_SOURCE_DIR}/tests/fuzz/corpus/${target})
endforeach()
