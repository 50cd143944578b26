// A small least-recently-used cache of rendered things (map pictures, grids) shared by the dashboard's
// handlers: rendering is the slow part of a page, and pages ask for the same maps several times. Internal to
// server/.
//
// Thread safety: all members lock; rendering happens outside the lock (two threads may render one key at
// once; both results are equal, the later one is kept).
#pragma once

#include <cstddef>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "storage/status.h"

namespace server {

template <typename Value>
class RenderCache {
 public:
  explicit RenderCache(std::size_t capacity) : capacity_(capacity) {}

  /// The cached value of `key`, or what `render()` (returning storage::Result<Value>) makes, then cached.
  template <typename Render>
  storage::Result<std::shared_ptr<const Value>> Get(const std::string& key, Render render) {
    {
      std::lock_guard lock(mutex_);
      for (auto it = entries_.begin(); it != entries_.end(); ++it) {
        if (it->first != key) continue;
        entries_.splice(entries_.begin(), entries_, it);
        return entries_.front().second;
      }
    }
    auto rendered = render();
    if (!rendered.ok()) return rendered.status();
    auto shared = std::make_shared<const Value>(std::move(rendered).value());
    std::lock_guard lock(mutex_);
    entries_.emplace_front(key, shared);
    while (entries_.size() > capacity_) entries_.pop_back();
    return shared;
  }

 private:
  const std::size_t capacity_;
  std::mutex mutex_;  // guards entries_
  std::list<std::pair<std::string, std::shared_ptr<const Value>>> entries_;  // most recent first
};

}  // namespace server
