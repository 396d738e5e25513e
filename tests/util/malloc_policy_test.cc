// The serving malloc policy (common/util/malloc_policy.h), by its effect on glibc's heap
// in this process: before it, a 16 MiB block is mapped on its own; after it, blocks under
// 32 MiB come from the heap, larger ones are still mapped, and freeing a block at the top
// of the heap keeps the memory (up to 64 MiB) instead of trimming it.
#include "common/util/malloc_policy.h"

#include <gtest/gtest.h>
#include <malloc.h>

#include <cstdlib>
#include <cstring>

namespace sceneloc {
namespace {

constexpr size_t kMiB = size_t{1} << 20;

// Keeps the compiler from dropping an allocation that is never read.
void* volatile sink = nullptr;

// Allocates and touches `bytes`; returns the block.
void* Allocate(size_t bytes) {
  void* block = std::malloc(bytes);
  if (block != nullptr) std::memset(block, 1, bytes);
  sink = block;
  return block;
}

size_t MappedBytes() { return mallinfo2().hblkhd; }  // in blocks mapped on their own
size_t HeapBytes() { return mallinfo2().arena; }     // the heap proper (all arenas)

// One test, in its own process (ctest runs each alone): the policy is process-wide and
// glibc's defaults are only seen before it.
TEST(MallocPolicyTest, LargeBlocksComeFromTheHeapAndStayThere) {
  const size_t mapped_before = MappedBytes();
  void* control = Allocate(16 * kMiB);
  ASSERT_NE(control, nullptr);
  if (MappedBytes() == mapped_before) {
    std::free(control);
    GTEST_SKIP() << "malloc is not glibc's here (a sanitizer build): the policy does nothing";
  }
  std::free(control);  // glibc raises its sliding threshold to 16 MiB: 24 MiB is still mapped

  UseServingMallocPolicy();
  const size_t mapped = MappedBytes();
  void* first = Allocate(24 * kMiB);
  void* second = Allocate(24 * kMiB);
  ASSERT_TRUE(first != nullptr && second != nullptr);
  EXPECT_EQ(MappedBytes(), mapped) << "a 24 MiB block was mapped: the threshold is not 32 MiB";
  EXPECT_GE(HeapBytes(), 48 * kMiB);
  void* large = Allocate(40 * kMiB);
  ASSERT_NE(large, nullptr);
  EXPECT_GE(MappedBytes(), mapped + 40 * kMiB) << "a 40 MiB block came from the heap";
  std::free(large);
  EXPECT_EQ(MappedBytes(), mapped);  // a mapped block goes back to the system at once

  // 48 MiB free at the top of the heap: kept under the 64 MiB trim threshold (glibc's own,
  // at most twice its sliding mmap threshold, would give it back).
  std::free(second);
  std::free(first);
  EXPECT_GE(HeapBytes(), 48 * kMiB) << "the heap was trimmed after 48 MiB were freed";
}

}  // namespace
}  // namespace sceneloc
