# Precompiled headers for the clean build without a compiler cache
# (docs/building.md). Most translation units parse Eigen and the standard
# library, and every test parses GoogleTest: a few CPU seconds per file before
# any of our code. The libraries and executables each precompile that set
# once; the ~150 test programs share one precompiled header, compiled with
# their flags by graphslam_test_headers. The generated code is the same.
#
# Off by default when a compiler launcher (ccache) is set: ccache does not
# cache compiles that use a precompiled header unless its sloppiness is set
# to pch_defines,time_macros, and a warm cache beats precompiled headers.
if(CMAKE_CXX_COMPILER_LAUNCHER)
  set(_graphslam_pch_default OFF)
else()
  set(_graphslam_pch_default ON)
endif()
option(GRAPHSLAM_PRECOMPILED_HEADERS "Precompile Eigen, GoogleTest and the standard headers"
       ${_graphslam_pch_default})

set(GRAPHSLAM_COMMON_HEADERS
  <Eigen/Core> <Eigen/Cholesky> <Eigen/Geometry>
  <algorithm> <cmath> <cstdint> <filesystem> <fstream> <functional> <map>
  <memory> <sstream> <string> <vector>)

# graphslam_precompile_headers(<target>): <target> precompiles the headers
# most of our sources include.
function(graphslam_precompile_headers target)
  if(GRAPHSLAM_PRECOMPILED_HEADERS)
    target_precompile_headers(${target} PRIVATE ${GRAPHSLAM_COMMON_HEADERS})
  endif()
endfunction()
