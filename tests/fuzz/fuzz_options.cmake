# libFuzzer build (tests/fuzz/run_fuzzers.sh): with GRAPHSLAM_BUILD_FUZZERS=ON
# and clang, everything is compiled with coverage instrumentation and ASan +
# UBSan. Included by the top-level CMakeLists.txt before the libraries.
option(GRAPHSLAM_BUILD_FUZZERS "Build the libFuzzer targets (clang only)" OFF)
if(GRAPHSLAM_BUILD_FUZZERS)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "GRAPHSLAM_BUILD_FUZZERS needs clang (tests/fuzz/run_fuzzers.sh)")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all
                      -fno-omit-frame-pointer -g)
  add_link_options(-fsanitize=address,undefined)
endif()
