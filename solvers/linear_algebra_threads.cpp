#include "solvers/linear_algebra_threads.h"

#include <dlfcn.h>

#include <initializer_list>

namespace goo {

bool set_linear_algebra_threads(int threads) {
  using SetThreads = void (*)(int);
  bool found = false;
  for (const char* name : {"openblas_set_num_threads", "goto_set_num_threads"}) {
    if (void* symbol = dlsym(RTLD_DEFAULT, name)) {
      reinterpret_cast<SetThreads>(symbol)(threads);
      found = true;
      break;
    }
  }
  if (void* symbol = dlsym(RTLD_DEFAULT, "omp_set_num_threads")) reinterpret_cast<SetThreads>(symbol)(threads);
  return found;
}

}  // namespace goo
