// The one name table of each closed set of states on records (records.h): the spellings stored in the TEXT
// columns, unchanged since the columns held free strings, so existing databases read as before.
#include <string>

#include "storage/records.h"

namespace storage {
namespace {

/// INVALID_ARGUMENT: `name` is not a spelling of `what`; lists the spellings `values` have.
template <typename E, std::size_t N>
Result<E> ParseIn(const std::array<E, N>& values, std::string_view name, std::string_view what) {
  for (E value : values) {
    if (Name(value) == name) return value;
  }
  std::string expected;
  for (std::size_t i = 0; i < N; ++i) {
    expected += i == 0 ? "" : i + 1 == N ? " or " : ", ";
    expected += Name(values[i]);
  }
  return InvalidArgument(std::string(what) + " \"" + std::string(name.substr(0, 64)) + "\" is not " +
                         expected);
}

}  // namespace

std::string_view Name(MapOrigin origin) {
  switch (origin) {
    case MapOrigin::kUpload: return "upload";
    case MapOrigin::kRepair: return "repair";
    case MapOrigin::kRollback: return "rollback";
    case MapOrigin::kUndo: return "undo";
    case MapOrigin::kImport: return "import";
  }
  return "?";
}

std::string_view Name(MapApproval approval) {
  switch (approval) {
    case MapApproval::kApproved: return "approved";
    case MapApproval::kPending: return "pending";
    case MapApproval::kRejected: return "rejected";
    case MapApproval::kStale: return "stale";
  }
  return "?";
}

std::string_view Name(MapAction action) {
  switch (action) {
    case MapAction::kRejectEdge: return "reject_edge";
    case MapAction::kRejectHypothesis: return "reject_hypothesis";
    case MapAction::kCutRegion: return "cut_region";
    case MapAction::kRollback: return "rollback";
    case MapAction::kUndo: return "undo";
    case MapAction::kImport: return "import";
  }
  return "?";
}

std::string_view Name(FindingState state) {
  switch (state) {
    case FindingState::kOpen: return "open";
    case FindingState::kResolved: return "resolved";
    case FindingState::kInfo: return "info";
  }
  return "?";
}

std::string_view Name(FindingKind kind) {
  switch (kind) {
    case FindingKind::kHighResidualEdge: return "high_residual_edge";
    case FindingKind::kUnconfirmedHypothesis: return "unconfirmed_hypothesis";
    case FindingKind::kUndoneMerge: return "undone_merge";
    case FindingKind::kRetractedHypothesis: return "retracted_hypothesis";
    case FindingKind::kProtrusion: return "protrusion";
    case FindingKind::kAmbiguousView: return "ambiguous_view";
    case FindingKind::kAlignment: return "alignment";
    case FindingKind::kMisaligned: return "misaligned";
    case FindingKind::kNewRegion: return "new_region";
    case FindingKind::kLostRegion: return "lost_region";
  }
  return "?";
}

std::string_view Name(JobState state) {
  switch (state) {
    case JobState::kQueued: return "queued";
    case JobState::kLeased: return "leased";
    case JobState::kDone: return "done";
    case JobState::kFailed: return "failed";
    case JobState::kCancelled: return "cancelled";
  }
  return "?";
}

// Every enumerator is in its list (the lists drive Parse and the round-trip tests).
static_assert(kMapOrigins.size() == static_cast<std::size_t>(MapOrigin::kImport) + 1);
static_assert(kMapApprovals.size() == static_cast<std::size_t>(MapApproval::kStale) + 1);
static_assert(kMapActions.size() == static_cast<std::size_t>(MapAction::kImport) + 1);
static_assert(kFindingStates.size() == static_cast<std::size_t>(FindingState::kInfo) + 1);
static_assert(kFindingKinds.size() == static_cast<std::size_t>(FindingKind::kLostRegion) + 1);
static_assert(kJobStates.size() == static_cast<std::size_t>(JobState::kCancelled) + 1);

template <>
Result<MapOrigin> Parse<MapOrigin>(std::string_view name) {
  return ParseIn(kMapOrigins, name, "map version origin");
}
template <>
Result<MapApproval> Parse<MapApproval>(std::string_view name) {
  return ParseIn(kMapApprovals, name, "map version approval");
}
template <>
Result<MapAction> Parse<MapAction>(std::string_view name) {
  return ParseIn(kMapActions, name, "map version action");
}
template <>
Result<FindingState> Parse<FindingState>(std::string_view name) {
  return ParseIn(kFindingStates, name, "finding state");
}
template <>
Result<FindingKind> Parse<FindingKind>(std::string_view name) {
  return ParseIn(kFindingKinds, name, "finding kind");
}
template <>
Result<JobState> Parse<JobState>(std::string_view name) {
  return ParseIn(kJobStates, name, "job state");
}

}  // namespace storage
