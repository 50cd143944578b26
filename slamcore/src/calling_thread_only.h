// Keeps CHOLMOD's factorisations on the calling thread.
//
// Debian's CHOLMOD is built with OpenMP: its supernodal factorisation opens parallel regions of
// CHOLMOD_OMP_NUM_THREADS (4) threads for large supernodes, whatever the machine or the caller. The Mapper
// is single-threaded by design (one core of a robot; one analysis per core on the server), so those regions
// only add thread hand-offs: on 2 cores they made the Manhattan 3500 replay 1.5× slower (7.9 s against 5.2 s
// with OMP_THREAD_LIMIT=1, the same χ²). The `num_threads` clause overrides OMP_NUM_THREADS and
// omp_set_num_threads; OpenMP 5.0's max-active-levels-var = 0 does not, and it is per thread, so it is set
// around each factorisation and restored after.
#pragma once

namespace slamcore::internal {

class CallingThreadOnly {
 public:
  CallingThreadOnly();
  ~CallingThreadOnly();
  CallingThreadOnly(const CallingThreadOnly&) = delete;
  CallingThreadOnly& operator=(const CallingThreadOnly&) = delete;

 private:
  int saved_max_active_levels_;
};

}  // namespace slamcore::internal
