// MemoryBudget: reservations within the capacity, waiting for a release, and giving up at
// the deadline.
#include "server/memory_budget.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

namespace sceneloc {
namespace {

using Clock = MemoryBudget::Clock;

TEST(MemoryBudgetTest, ReservesWithinTheCapacity) {
  MemoryBudget budget(100);
  const auto soon = Clock::now() + std::chrono::seconds(5);
  {
    MemoryBudget::Lease a = budget.Acquire(60, soon);
    MemoryBudget::Lease b = budget.Acquire(40, soon);
    EXPECT_TRUE(a.held());
    EXPECT_TRUE(b.held());
    EXPECT_EQ(budget.in_use(), 100);
  }
  EXPECT_EQ(budget.in_use(), 0);  // leases give their bytes back
}

TEST(MemoryBudgetTest, WaitsForARelease) {
  MemoryBudget budget(100);
  auto first = std::make_unique<MemoryBudget::Lease>(
      budget.Acquire(80, Clock::now() + std::chrono::seconds(5)));
  ASSERT_TRUE(first->held());
  std::atomic<bool> got{false};
  std::thread waiter([&] {
    const MemoryBudget::Lease second = budget.Acquire(50, Clock::now() + std::chrono::seconds(30));
    got = second.held();
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(got);  // 80 + 50 > 100: still waiting
  first.reset();      // the release wakes it
  waiter.join();
  EXPECT_TRUE(got);
  EXPECT_EQ(budget.in_use(), 0);
}

TEST(MemoryBudgetTest, GivesUpAtTheDeadline) {
  MemoryBudget budget(100);
  const MemoryBudget::Lease held = budget.Acquire(100, Clock::now() + std::chrono::seconds(5));
  const auto start = Clock::now();
  const MemoryBudget::Lease refused = budget.Acquire(1, start + std::chrono::milliseconds(50));
  EXPECT_FALSE(refused.held());
  EXPECT_GE(Clock::now() - start, std::chrono::milliseconds(50));
  EXPECT_EQ(budget.in_use(), 100);
}

}  // namespace
}  // namespace sceneloc
