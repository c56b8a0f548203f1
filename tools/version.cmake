# `graphslam --version` (tools/version.h): the commit and the dependency
# versions, captured at configure time into build_info.h.
execute_process(
  COMMAND git -C "${PROJECT_SOURCE_DIR}" rev-parse --short=12 HEAD
  OUTPUT_VARIABLE GRAPHSLAM_GIT_COMMIT
  OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
if(NOT GRAPHSLAM_GIT_COMMIT)
  set(GRAPHSLAM_GIT_COMMIT "unknown")
endif()
# SuiteSparse 5 has no CMake package: read the version macros of its headers.
function(graphslam_header_version header prefix out)
  file(STRINGS "${header}" lines REGEX "#define ${prefix}_(MAIN|SUB|SUBSUB)_VERSION ")
  set(parts "")
  foreach(level MAIN SUB SUBSUB)
    foreach(line IN LISTS lines)
      if(line MATCHES "#define ${prefix}_${level}_VERSION +([0-9]+)")
        list(APPEND parts "${CMAKE_MATCH_1}")
      endif()
    endforeach()
  endforeach()
  list(JOIN parts "." version)
  if(NOT version)
    set(version "unknown")
  endif()
  set(${out} "${version}" PARENT_SCOPE)
endfunction()
graphslam_header_version("${CHOLMOD_INCLUDE_DIR}/cholmod_core.h" CHOLMOD GRAPHSLAM_CHOLMOD_VERSION)
graphslam_header_version("${CHOLMOD_INCLUDE_DIR}/SuiteSparse_config.h" SUITESPARSE
  GRAPHSLAM_SUITESPARSE_VERSION)
configure_file(build_info.h.in "${CMAKE_CURRENT_BINARY_DIR}/generated/tools/build_info.h" @ONLY)
target_include_directories(graphslam_tools PRIVATE "${CMAKE_CURRENT_BINARY_DIR}/generated")
