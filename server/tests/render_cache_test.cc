// RenderCache: bounded by bytes, least recently used out first, oversized values not kept, one rendering
// per key however many ask at once.
#include "render_cache.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "status_matchers.h"

namespace server {
namespace {

RenderCache<std::string> MakeCache(std::size_t max_bytes) {
  return RenderCache<std::string>(max_bytes, [](const std::string& value) { return value.size(); });
}

TEST(RenderCacheTest, EvictsLeastRecentlyUsedByBytes) {
  auto cache = MakeCache(100);
  int renders = 0;
  auto render = [&](char c, std::size_t n) {
    return [&renders, c, n]() -> storage::Result<std::string> {
      ++renders;
      return std::string(n, c);
    };
  };
  ASSERT_THAT(cache.Get("a", render('a', 40)), IsOk());
  ASSERT_THAT(cache.Get("b", render('b', 40)), IsOk());
  EXPECT_EQ(cache.bytes(), 80u);
  ASSERT_THAT(cache.Get("a", render('a', 40)), IsOk());  // hit: "a" is now the most recent
  EXPECT_EQ(renders, 2);
  ASSERT_THAT(cache.Get("c", render('c', 40)), IsOk());  // 120 > 100: "b" (least recent) leaves
  EXPECT_EQ(cache.bytes(), 80u);
  ASSERT_THAT(cache.Get("a", render('a', 40)), IsOk());
  EXPECT_EQ(renders, 3);
  ASSERT_THAT(cache.Get("b", render('b', 40)), IsOk());
  EXPECT_EQ(renders, 4);
  // Larger than the whole budget: answered, not kept, nothing else evicted for it.
  const std::size_t before = cache.bytes();
  auto huge = cache.Get("huge", render('h', 1000));
  ASSERT_THAT(huge, IsOk());
  EXPECT_EQ((*huge)->size(), 1000u);
  EXPECT_EQ(cache.bytes(), before);
}

TEST(RenderCacheTest, ConcurrentRequestsForOneKeyRenderOnce) {
  auto cache = MakeCache(1 << 20);
  std::atomic<int> renders{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&] {
      auto value = cache.Get("map", [&]() -> storage::Result<std::string> {
        ++renders;
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        return std::string("rendered");
      });
      EXPECT_THAT(value, IsOk());
      EXPECT_EQ(**value, "rendered");
    });
  }
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(renders.load(), 1);
}

TEST(RenderCacheTest, AFailedRenderingIsNotCachedAndWakesTheWaiters) {
  auto cache = MakeCache(1 << 20);
  auto failed = cache.Get("x", []() -> storage::Result<std::string> { return storage::NotFound("no map"); });
  EXPECT_FALSE(failed.ok());
  auto later = cache.Get("x", []() -> storage::Result<std::string> { return std::string("ok"); });
  ASSERT_THAT(later, IsOk());
  EXPECT_EQ(**later, "ok");
}

}  // namespace
}  // namespace server
