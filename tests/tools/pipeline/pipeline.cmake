# The application layer (tools/pipeline): requests, and the one solve path on
# real 2-D and 3-D files.
graphslam_test(tools/pipeline/solve_request)
graphslam_test(tools/pipeline/solve_pipeline)
