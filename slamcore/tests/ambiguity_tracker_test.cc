#include "../src/ambiguity_tracker.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace slamcore::internal {
namespace {

// Views created in id order: view 1 before view 2 before view 3.
std::size_t CreationOrder(ViewId view) { return static_cast<std::size_t>(view); }
bool NeverMarked(ViewId) { return false; }

TEST(AmbiguityTrackerTest, CandidateWithATrustedAcceptedObservationIsAmbiguous) {
  AmbiguityTracker tracker(/*window_distance=*/4.0, /*min_rejections=*/2);
  tracker.AddAccepted(1, 0.0);
  tracker.AddRejected(2, 0.5);
  EXPECT_TRUE(tracker.FindAmbiguous(CreationOrder, NeverMarked).empty());  // one rejection only
  tracker.AddRejected(2, 1.0);
  EXPECT_THAT(tracker.FindAmbiguous(CreationOrder, NeverMarked), ::testing::ElementsAre(2));
  EXPECT_TRUE(tracker.FindAmbiguous(CreationOrder, [](ViewId v) { return v == 2; }).empty());
}

TEST(AmbiguityTrackerTest, AnAcceptedObservationOfANewerViewIsNotTrusted) {
  AmbiguityTracker tracker(4.0, 2);
  tracker.AddAccepted(3, 0.0);  // created after the candidate
  tracker.AddAccepted(2, 0.0);  // the candidate itself
  tracker.AddRejected(2, 0.5);
  tracker.AddRejected(2, 0.6);
  EXPECT_TRUE(tracker.FindAmbiguous(CreationOrder, NeverMarked).empty());
}

TEST(AmbiguityTrackerTest, ObservationsAreForgottenAfterTheWindowDistance) {
  AmbiguityTracker tracker(4.0, 2);
  tracker.AddAccepted(1, 0.0);
  tracker.AddRejected(2, 0.0);
  tracker.AddRejected(2, 3.0);
  tracker.Forget(4.0);  // exactly the window: still held
  EXPECT_EQ(tracker.RejectionsInWindow(2), 2);
  EXPECT_THAT(tracker.FindAmbiguous(CreationOrder, NeverMarked), ::testing::ElementsAre(2));
  tracker.Forget(4.5);  // the rejection at 0 and the accepted observation at 0 are gone
  EXPECT_EQ(tracker.RejectionsInWindow(2), 1);
  tracker.AddRejected(2, 4.5);
  EXPECT_TRUE(tracker.FindAmbiguous(CreationOrder, NeverMarked).empty());  // no trusted view left
}

TEST(AmbiguityTrackerTest, LateRejectionsKeepOdometerOrderAndCanBeTakenBack) {
  AmbiguityTracker tracker(4.0, 2);
  tracker.AddRejected(2, 5.0);
  tracker.AddRejected(3, 1.0);  // added late, made earlier
  tracker.Forget(5.5);          // forgets the one at 1.0 even though it was added last
  EXPECT_EQ(tracker.RejectionsInWindow(3), 0);
  EXPECT_EQ(tracker.RejectionsInWindow(2), 1);
  tracker.RemoveRejected(2, 5.0);
  EXPECT_EQ(tracker.RejectionsInWindow(2), 0);
  tracker.RemoveRejected(2, 5.0);  // nothing left to remove: no effect
  EXPECT_EQ(tracker.RejectionsInWindow(2), 0);
}

TEST(AmbiguityTrackerTest, ForgettingAcceptedObservationsRemovesTrust) {
  AmbiguityTracker tracker(4.0, 2);
  tracker.AddAccepted(1, 0.0);
  tracker.AddRejected(2, 0.1);
  tracker.AddRejected(2, 0.2);
  tracker.ForgetAccepted();
  EXPECT_TRUE(tracker.FindAmbiguous(CreationOrder, NeverMarked).empty());
}

}  // namespace
}  // namespace slamcore::internal
