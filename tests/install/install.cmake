# `cmake --install` + find_package(graphslam) + docs/example (issue 23).
add_test(NAME install_example
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/install/install_example_test.sh
    ${CMAKE_BINARY_DIR} ${PROJECT_SOURCE_DIR}
    ${PROJECT_SOURCE_DIR}/../shared/datasets/freiburg_course_g2o/intel.g2o)
set_tests_properties(install_example PROPERTIES SKIP_RETURN_CODE 77 TIMEOUT 600)
