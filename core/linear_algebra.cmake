# Block-sparse matrices, Schur elimination, PCG, CHOLMOD.
target_sources(graphslam_core PRIVATE
  block_jacobi_preconditioner.cc
  block_sparse_matrix.cc
  cholmod_solver.cc
  incomplete_cholesky_preconditioner.cc
  preconditioned_conjugate_gradient.cc
  reduced_system_solver.cc
  schur_eliminator.cc
  serial_openmp.cc
  subgraph_preconditioner.cc
  suitesparse_clock.cc
  trajectory_deflation.cc)
# CHOLMOD's OpenMP regions are made serial (core/serial_openmp.h): only
# omp_set_max_active_levels and dlvsym for libgomp's GOMP_parallel, no
# -fopenmp here.
find_package(OpenMP REQUIRED COMPONENTS CXX)
target_link_libraries(graphslam_core PRIVATE ${OpenMP_CXX_LIBRARIES} ${CMAKE_DL_LIBS})
# core/suitesparse_clock.h: CHOLMOD's clock, which nothing of ours calls,
# linked into every program that links graphslam_core.
target_link_options(graphslam_core INTERFACE "LINKER:--undefined=SuiteSparse_time")
