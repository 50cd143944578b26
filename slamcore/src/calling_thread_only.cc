#include "calling_thread_only.h"

#include <omp.h>

namespace slamcore::internal {

CallingThreadOnly::CallingThreadOnly() : saved_max_active_levels_(omp_get_max_active_levels()) {
  omp_set_max_active_levels(0);
}

CallingThreadOnly::~CallingThreadOnly() { omp_set_max_active_levels(saved_max_active_levels_); }

}  // namespace slamcore::internal
