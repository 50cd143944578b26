#include "ambiguity_tracker.h"

#include <algorithm>
#include <limits>

namespace slamcore::internal {
namespace {

/// Keeps the deque sorted by odometer even when an old observation is added late (a merge hypothesis's
/// observations become rejected only when the hypothesis is dropped).
template <typename Deque, typename Stamped>
void InsertSorted(Deque& deque, const Stamped& entry) {
  const auto position =
      std::upper_bound(deque.begin(), deque.end(), entry.odometer,
                       [](double odometer, const Stamped& e) { return odometer < e.odometer; });
  deque.insert(position, entry);
}

}  // namespace

void AmbiguityTracker::AddRejected(ViewId view, double odometer) {
  InsertSorted(rejected_, Stamped{view, odometer});
  ++rejections_by_view_[view];
}

void AmbiguityTracker::AddAccepted(ViewId view, double odometer) {
  InsertSorted(accepted_, Stamped{view, odometer});
}

void AmbiguityTracker::RemoveRejected(ViewId view, double odometer) {
  const auto it = std::find_if(rejected_.begin(), rejected_.end(),
                               [&](const Stamped& e) { return e.view == view && e.odometer == odometer; });
  if (it == rejected_.end()) return;
  rejected_.erase(it);
  const auto count = rejections_by_view_.find(view);
  if (--count->second == 0) rejections_by_view_.erase(count);
}

void AmbiguityTracker::Forget(double odometer) {
  while (!rejected_.empty() && odometer - rejected_.front().odometer > window_distance_) {
    const auto count = rejections_by_view_.find(rejected_.front().view);
    if (--count->second == 0) rejections_by_view_.erase(count);
    rejected_.pop_front();
  }
  while (!accepted_.empty() && odometer - accepted_.front().odometer > window_distance_)
    accepted_.pop_front();
}

int AmbiguityTracker::RejectionsInWindow(ViewId view) const {
  const auto count = rejections_by_view_.find(view);
  return count == rejections_by_view_.end() ? 0 : count->second;
}

std::vector<ViewId> AmbiguityTracker::FindAmbiguous(const std::function<std::size_t(ViewId)>& creation_order,
                                                    const std::function<bool(ViewId)>& already_marked) const {
  // The oldest view with an accepted observation in the window is the most trusting witness: any
  // candidate created after it has a trusted view.
  std::size_t oldest_accepted = std::numeric_limits<std::size_t>::max();
  for (const Stamped& entry : accepted_)
    oldest_accepted = std::min(oldest_accepted, creation_order(entry.view));

  std::vector<ViewId> ambiguous;
  for (const auto& [view, count] : rejections_by_view_) {
    if (count < min_rejections_ || already_marked(view)) continue;
    if (oldest_accepted < creation_order(view)) ambiguous.push_back(view);
  }
  std::sort(ambiguous.begin(), ambiguous.end(),
            [&](ViewId a, ViewId b) { return creation_order(a) < creation_order(b); });
  return ambiguous;
}

}  // namespace slamcore::internal
