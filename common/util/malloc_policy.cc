#include "common/util/malloc_policy.h"

#include <malloc.h>

namespace sceneloc {

void UseServingMallocPolicy() {
  // Fixed values also turn off glibc's sliding mmap threshold, so the policy does not
  // depend on what the process happened to free first.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
}

}  // namespace sceneloc
