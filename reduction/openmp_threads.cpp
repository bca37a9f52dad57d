#include "reduction/openmp_threads.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace rgbdcast {

int openmp_threads(int requested) {
  if (requested > 0) return requested;
#ifdef _OPENMP
  return omp_get_max_threads() > 0 ? omp_get_max_threads() : 1;
#else
  return 1;
#endif
}

}  // namespace rgbdcast
