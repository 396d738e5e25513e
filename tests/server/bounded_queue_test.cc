// BoundedQueue: refuses at capacity, hands items over in order, Close wakes and returns;
// large items hold at most their holders.
#include "server/bounded_queue.h"

#include <gtest/gtest.h>

#include <optional>
#include <thread>
#include <vector>

namespace sceneloc {
namespace {

// A full queue refuses at once and leaves the item with the caller.
TEST(BoundedQueueTest, RefusesWhenFull) {
  BoundedQueue<std::unique_ptr<int>> queue(2);
  auto a = std::make_unique<int>(1), b = std::make_unique<int>(2), c = std::make_unique<int>(3);
  EXPECT_TRUE(queue.TryPush(a));
  EXPECT_TRUE(queue.TryPush(b));
  EXPECT_FALSE(queue.TryPush(c));
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(*c, 3);
  EXPECT_EQ(**queue.Pop(), 1);
  EXPECT_TRUE(queue.TryPush(c));
  EXPECT_EQ(queue.size(), 2u);
}

// Close wakes a blocked Pop with nullopt and returns what was left; pushes then fail.
TEST(BoundedQueueTest, CloseWakesPoppersAndReturnsLeftovers) {
  BoundedQueue<int> empty(1);
  std::thread popper([&] { EXPECT_FALSE(empty.Pop().has_value()); });
  EXPECT_TRUE(empty.Close().empty());
  popper.join();

  BoundedQueue<int> queue(3);
  int one = 1, two = 2;
  ASSERT_TRUE(queue.TryPush(one));
  ASSERT_TRUE(queue.TryPush(two));
  EXPECT_EQ(queue.Close(), (std::vector<int>{1, 2}));
  int three = 3;
  EXPECT_FALSE(queue.TryPush(three));
  EXPECT_FALSE(queue.Pop().has_value());
}

// With one large holder: a second large item waits until the first is Done, while small
// items behind it are taken; otherwise the oldest item first.
TEST(BoundedQueueTest, LargeItemsHoldAtMostTheirHolders) {
  BoundedQueue<int> queue(10, /*large_holders=*/1);
  int l1 = 1, l2 = 2, s1 = 3, s2 = 4;
  ASSERT_TRUE(queue.TryPush(l1, true));
  ASSERT_TRUE(queue.TryPush(l2, true));
  ASSERT_TRUE(queue.TryPush(s1));
  ASSERT_TRUE(queue.TryPush(s2));
  bool large = false;
  EXPECT_EQ(queue.TryPop(&large), 1);
  EXPECT_TRUE(large);
  EXPECT_EQ(queue.large_held(), 1);
  EXPECT_EQ(queue.TryPop(&large), 3);  // l2 may not be taken: the small one behind it is
  EXPECT_FALSE(large);
  queue.Done(false);  // a small item's Done changes nothing
  EXPECT_EQ(queue.TryPop(&large), 4);
  EXPECT_FALSE(queue.TryPop(&large).has_value());  // only l2 is left, and may not be taken
  EXPECT_EQ(queue.size(), 1u);
  queue.Done(true);
  EXPECT_EQ(queue.large_held(), 0);
  EXPECT_EQ(queue.TryPop(&large), 2);
  EXPECT_TRUE(large);

  // With holders free, arrival order across the lanes.
  BoundedQueue<int> ordered(10, 2);
  int a = 1, b = 2, c = 3;
  ASSERT_TRUE(ordered.TryPush(a));
  ASSERT_TRUE(ordered.TryPush(b, true));
  ASSERT_TRUE(ordered.TryPush(c));
  EXPECT_EQ(ordered.TryPop(), 1);
  EXPECT_EQ(ordered.TryPop(), 2);
  EXPECT_EQ(ordered.TryPop(), 3);
  // Capacity counts both lanes.
  BoundedQueue<int> full(2, 1);
  ASSERT_TRUE(full.TryPush(a, true));
  ASSERT_TRUE(full.TryPush(b));
  EXPECT_FALSE(full.TryPush(c));
  EXPECT_FALSE(full.TryPush(c, true));
}

// A consumer blocked because every large holder is busy wakes when one is Done; Close
// returns what is left in arrival order across the lanes.
TEST(BoundedQueueTest, ADoneLargeItemWakesAWaitingConsumer) {
  BoundedQueue<int> queue(10, 1);
  int l1 = 1, l2 = 2;
  ASSERT_TRUE(queue.TryPush(l1, true));
  ASSERT_TRUE(queue.TryPush(l2, true));
  bool large = false;
  ASSERT_EQ(queue.Pop(&large), 1);
  std::optional<int> second;
  std::thread waiter([&] { second = queue.Pop(); });
  queue.Done(true);
  waiter.join();
  EXPECT_EQ(second, 2);

  BoundedQueue<int> left(10, 1);
  int a = 1, b = 2, c = 3, d = 4;
  ASSERT_TRUE(left.TryPush(a, true));
  ASSERT_TRUE(left.TryPush(b));
  ASSERT_TRUE(left.TryPush(c, true));
  ASSERT_TRUE(left.TryPush(d));
  EXPECT_EQ(left.Close(), (std::vector<int>{1, 2, 3, 4}));
  EXPECT_FALSE(left.TryPop().has_value());
}

}  // namespace
}  // namespace sceneloc
