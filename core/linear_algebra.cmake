# Block-sparse matrices, Schur elimination, PCG, CHOLMOD.
target_sources(graphslam_core PRIVATE)
