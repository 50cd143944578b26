// AmbiguityTracker: the ambiguous-view detector of paper IV-A (Fig. 3).
//
// Two distance trackers hold observations stamped with the robot's odometer when they were made; an
// observation is forgotten once the robot has travelled more than `window_distance` since. A view with at
// least `min_rejections` rejected observations in the window is a candidate; a candidate is ambiguous
// when the accepted tracker also holds an observation of a *trusted* view, one created before the
// candidate (creation order = the order views were added to the graph), because then the robot was
// certain of its position while the candidate kept contradicting it.
//
// What counts as "rejected" is the Mapper's choice (mapper_impl.h); this class only counts.
// Memory and time are O(observations in the window).
//
// Thread safety: a value; not safe for concurrent use.
#pragma once

#include <cstddef>
#include <deque>
#include <functional>
#include <unordered_map>
#include <vector>

#include "slamcore/pose_graph.h"

namespace slamcore::internal {

class AmbiguityTracker {
 public:
  AmbiguityTracker(double window_distance, int min_rejections)
      : window_distance_(window_distance), min_rejections_(min_rejections) {}

  void AddRejected(ViewId view, double odometer);
  void AddAccepted(ViewId view, double odometer);
  /// Takes back one rejected observation of `view` made at `odometer` (a no-op when none is held), for
  /// observations that turned out right after all.
  void RemoveRejected(ViewId view, double odometer);
  /// Forgets observations made more than the window before `odometer`.
  void Forget(double odometer);
  /// Forgets every accepted observation: after a kidnap the robot is no longer certain where it is.
  void ForgetAccepted() { accepted_.clear(); }

  /// Views that are candidates and have a trusted accepted observation in the window, in increasing view
  /// creation order. `creation_order(view)` ranks views; `already_marked(view)` excludes views marked
  /// before. Call Forget first.
  std::vector<ViewId> FindAmbiguous(const std::function<std::size_t(ViewId)>& creation_order,
                                    const std::function<bool(ViewId)>& already_marked) const;

  int RejectionsInWindow(ViewId view) const;

 private:
  struct Stamped {
    ViewId view;
    double odometer;
  };

  double window_distance_;
  int min_rejections_;
  std::deque<Stamped> rejected_;  // in increasing odometer order
  std::deque<Stamped> accepted_;
  std::unordered_map<ViewId, int> rejections_by_view_;
};

}  // namespace slamcore::internal
