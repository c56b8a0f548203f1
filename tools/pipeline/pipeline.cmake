# The application layer (tools/pipeline/solve_pipeline.h): options and job
# settings -> a validated SolveRequest -> detect, read, initialize, solve,
# write, for both dimensions. The subcommands and the job runner call it.
target_sources(graphslam_tools PRIVATE
  pipeline/solve_2d.cc
  pipeline/solve_3d.cc
  pipeline/solve_pipeline.cc
  pipeline/solve_request.cc)
