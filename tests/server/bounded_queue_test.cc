// BoundedQueue: refuses at capacity, hands items over in order, Close wakes and returns.
#include "server/bounded_queue.h"

#include <gtest/gtest.h>

#include <thread>

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

}  // namespace
}  // namespace sceneloc
