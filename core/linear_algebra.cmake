# Block-sparse matrices, Schur elimination, PCG, CHOLMOD.
target_sources(graphslam_core PRIVATE
  block_jacobi_preconditioner.cc
  block_sparse_matrix.cc
  cholmod_solver.cc
  incomplete_cholesky_preconditioner.cc
  preconditioned_conjugate_gradient.cc
  reduced_system_solver.cc
  schur_eliminator.cc
  subgraph_preconditioner.cc
  trajectory_deflation.cc)
