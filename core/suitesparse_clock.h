// SuiteSparse_time, SuiteSparse's clock, defined by this library to return 0
// without reading the system clock.
//
// Why: Debian's CHOLMOD is built without NTIMER, so its supernodal numeric
// factorization reads the clock (clock_gettime) before and after each of its
// BLAS and LAPACK calls, only to add up statistics of its GPU code path
// (cholmod_common's CHOLMOD_CPU_*_TIME and CHOLMOD_GPU_*_TIME), which nothing
// here reads. On a pose graph with thousands of small supernodes that is tens
// of thousands of clock reads per solve (12 000 per factorization of M3500),
// a few per cent of the whole solve.
//
// How: the executable's definition comes first in the dynamic linker's
// search order, so CHOLMOD's calls land here, as GOMP_parallel's do in
// core/serial_openmp.h. The CMake list links this file into every program
// that links graphslam_core (LINKER:--undefined=SuiteSparse_time), since no
// code of ours calls it. CHOLMOD's statistics then add zeros; its call
// counters (CHOLMOD_CPU_*_CALLS) still count. libsuitesparseconfig's
// SuiteSparse_tic and SuiteSparse_toc still read the clock; CHOLMOD's
// factorization and solves do not call them.
//
// THREAD SAFETY: pure. ALLOCATION: none.
#pragma once

extern "C" double SuiteSparse_time(void);
