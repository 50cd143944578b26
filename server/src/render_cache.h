// A least-recently-used cache of rendered things (map pictures, grids) shared by the dashboard's handlers:
// rendering is the slow part of a page, and pages ask for the same maps several times. Internal to server/.
//
// Bounded by bytes, not entries: `size_of(value)` says what a value holds, the least recently used values
// leave while the total exceeds `max_bytes`, and a value larger than the whole budget is returned but not
// kept. Single flight: concurrent requests for one key wait for one rendering instead of each rendering it
// (a page's images arrive together).
//
// Thread safety: all members lock; rendering happens outside the lock.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <tuple>
#include <utility>

#include "storage/status.h"

namespace server {

template <typename Value>
class RenderCache {
 public:
  RenderCache(std::size_t max_bytes, std::function<std::size_t(const Value&)> size_of)
      : max_bytes_(max_bytes), size_of_(std::move(size_of)) {}

  /// The cached value of `key`, or what `render()` (returning storage::Result<Value>) makes, then cached.
  template <typename Render>
  storage::Result<std::shared_ptr<const Value>> Get(const std::string& key, Render render) {
    {
      std::unique_lock lock(mutex_);
      rendering_done_.wait(lock, [&] { return !rendering_.contains(key); });
      for (auto it = entries_.begin(); it != entries_.end(); ++it) {
        if (std::get<0>(*it) != key) continue;
        entries_.splice(entries_.begin(), entries_, it);
        return std::get<1>(entries_.front());
      }
      rendering_.insert(key);
    }
    struct Done {
      RenderCache* self;
      const std::string& key;
      ~Done() {
        std::lock_guard lock(self->mutex_);
        self->rendering_.erase(key);
        self->rendering_done_.notify_all();
      }
    } done{this, key};
    ASSIGN_OR_RETURN(auto rendered, render());
    auto shared = std::make_shared<const Value>(std::move(rendered));
    const std::size_t bytes = size_of_(*shared);
    std::lock_guard lock(mutex_);
    if (bytes > max_bytes_) return shared;
    entries_.emplace_front(key, shared, bytes);
    bytes_ += bytes;
    while (bytes_ > max_bytes_) {
      bytes_ -= std::get<2>(entries_.back());
      entries_.pop_back();
    }
    return shared;
  }

  /// Bytes held now (for tests and metrics).
  std::size_t bytes() const {
    std::lock_guard lock(mutex_);
    return bytes_;
  }

 private:
  const std::size_t max_bytes_;
  const std::function<std::size_t(const Value&)> size_of_;
  mutable std::mutex mutex_;  // guards entries_, bytes_, rendering_
  std::condition_variable rendering_done_;
  std::list<std::tuple<std::string, std::shared_ptr<const Value>, std::size_t>>
      entries_;  // most recent first
  std::size_t bytes_ = 0;
  std::set<std::string> rendering_;  // keys being rendered now
};

}  // namespace server
