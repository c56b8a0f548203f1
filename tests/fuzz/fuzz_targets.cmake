# The libFuzzer executables, one per input parser; built only with
# GRAPHSLAM_BUILD_FUZZERS=ON (tests/fuzz/run_fuzzers.sh), never by default.
set(GRAPHSLAM_FUZZ_TARGETS
  g2o_reader isam_reader native_log_reader mrclam_reader job_spec chunk_reader
  g2o_3d_reader isam_3d_reader threedtk_reader scan_store)
if(GRAPHSLAM_BUILD_FUZZERS)
  foreach(target ${GRAPHSLAM_FUZZ_TARGETS})
    add_executable(${target}_fuzzer ${PROJECT_SOURCE_DIR}/tests/fuzz/${target}_fuzzer.cc)
    target_include_directories(${target}_fuzzer PRIVATE ${PROJECT_SOURCE_DIR})
    # The file parsers need only storage and core; the job file parser only
    # its own source and the simulator options it validates.
    if(target STREQUAL "job_spec")
      target_sources(${target}_fuzzer PRIVATE ${PROJECT_SOURCE_DIR}/tools/job/job_spec.cc
                                              ${PROJECT_SOURCE_DIR}/tools/campus_simulator.cc)
      target_link_libraries(${target}_fuzzer PRIVATE graphslam_core yaml-cpp)
    else()
      target_link_libraries(${target}_fuzzer PRIVATE graphslam_storage graphslam_core)
    endif()
    target_link_options(${target}_fuzzer PRIVATE -fsanitize=fuzzer)
  endforeach()
endif()
