// SerialOpenMpRegions: while one lives, every OpenMP parallel region in the
// process runs on the thread that opens it, as the body of a one-thread team,
// and without creating that team.
//
// Why: Debian's CHOLMOD opens three OpenMP regions per supernode in its
// supernodal factorization (clearing a supernode, scattering its map,
// copying A into it), each with a fixed num_threads(4) clause that
// OMP_NUM_THREADS cannot lower. On 2 cores beside TBB's threads, four OpenMP
// threads per supernode cost more than they save, so they are made inactive
// (max-active-levels 0). An inactive region still costs libgomp a team of
// one: its allocation and a barrier whose release is a futex system call,
// about a microsecond per region, a quarter to a third of the factorization
// of a pose graph with thousands of small supernodes.
//
// How: max-active-levels is set to 0 (every region inactive; the previous
// value comes back on destruction), and GOMP_parallel, the entry point GCC
// compiles `#pragma omp parallel` to (CHOLMOD's only one), is defined here
// too. The executable's definition comes first in the dynamic linker's
// search order, so CHOLMOD's calls land here: with max-active-levels 0 the
// outlined body runs directly, where libgomp would run it on the same thread
// as a team of one (omp_get_num_threads() 1 and omp_get_thread_num() 0 in
// both cases; only omp_get_level() and omp_in_parallel() inside differ,
// which CHOLMOD does not call). Otherwise the call goes on to libgomp's
// GOMP_parallel unchanged, so OpenMP code elsewhere runs as before.
//
// max-active-levels is libgomp's process-wide setting: OpenMP regions other
// threads open meanwhile also run inactive (our own parallelism is TBB's).
//
// THREAD SAFETY: nest scopes on one thread; scopes on several threads at once
// must not overlap (the saved value is restored in destruction order).
// ALLOCATION: none.
#pragma once

namespace graphslam::core {

class SerialOpenMpRegions {
 public:
  SerialOpenMpRegions();
  ~SerialOpenMpRegions();
  SerialOpenMpRegions(const SerialOpenMpRegions&) = delete;
  SerialOpenMpRegions& operator=(const SerialOpenMpRegions&) = delete;

 private:
  int saved_;
};

}  // namespace graphslam::core
