// The fleet's read side — statistics, runs, reports, comparisons of parameter sets, labels, jobs — in one
// place, behind both transports (the Queries gRPC service and the dashboard's /api routes), as MapHistory is
// for maps. Each figure is computed here once: the paper's shares (absent when their denominator is 0), day
// keys, the Fig. 8 map histogram, the Fig. 12 confusion matrix and the comparison score.
//
// Who sees what (README "Safe to expose"): every method takes the caller. Engineers and admins read the
// fleet; a robot reads only its own runs — its filters are pinned to its own robot id, a run it names is
// looked up among its own (run_lookup.h), labels and jobs are those of its own runs. The transports decide
// which methods a robot reaches at all (gRPC: Permission::kRead; HTTP: MakeHttpAccessGuard).
//
// Thread safety: stateless apart from the repository (thread-safe); use from any thread.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "fleet/v1/report.pb.h"
#include "server/auth.h"
#include "storage/repository.h"

namespace server {

/// The counters of a set of reports with the paper's figures derived from them.
struct Figures {
  storage::FleetStatistics counts;
  std::optional<double> recovery_per_run;                       // Fig. 6
  std::optional<double> recovery_accepted_share;                // Fig. 6
  std::optional<double> started_localized_share;                // Fig. 7
  std::optional<double> merge_conditional_then_rejected_share;  // Fig. 7
  std::optional<double> ambiguous_view_share;                   // Fig. 8
  std::optional<double> protrusions_per_run;                    // Fig. 12
  std::optional<double> recovery_retracted_share;               // accepted recoveries taken back later
};
Figures FiguresOf(const storage::FleetStatistics& counts);

/// "2026-01-01" for storage's GroupBy::kDay key (days since the Unix epoch, UTC); other text unchanged.
std::string DayKey(const std::string& days_since_epoch);

struct FiguresGroup {
  std::string key;  // day keys as DayKey
  Figures figures;
};

struct StatisticsAnswer {
  Figures total;
  std::vector<FiguresGroup> groups;  // by key; empty without grouping
};

/// Fig. 8 over maps: a robot's lifelong map is one map.
struct MapsFigure {
  std::int64_t maps = 0;  // robots with views
  std::int64_t maps_with_ambiguous_views = 0;
  std::optional<double> share_with_ambiguous_views;
  std::array<std::int64_t, 10> ambiguous_share_histogram{};  // maps by share of ambiguous views, 10 bins
};

/// Fig. 12: the classifier's predictions against engineers' labels.
struct ConfusionMatrix {
  std::int64_t true_positive = 0, false_positive = 0, false_negative = 0, true_negative = 0;
  std::int64_t unclassified = 0;  // predicted neither class
  std::int64_t labelled = 0;
  std::optional<double> recall, precision, false_positive_rate;
};

struct RunsQuery {
  storage::RunFilter filter;
  int page_size = 100;  // 1..1000
  std::optional<storage::RunCursor> after;
  std::string report_set;          // the set whose report counters each row carries (empty: none)
  bool with_report_sets = false;   // list the sets each run has a report of
  bool with_regions = false;       // count each run's regions (of report_set) and labelled ones
  bool only_with_regions = false;  // skip runs without regions, reading up to 20 pages to fill this one
};

struct RunRow {
  storage::RunRecord run;
  std::optional<storage::ReportRecord> report;  // counters of report_set (no bytes)
  std::vector<std::string> report_sets;
  std::int64_t regions = 0, regions_labelled = 0;
};

struct RunsPage {
  std::vector<RunRow> rows;
  std::optional<storage::RunCursor> next;
};

struct RunChange {
  storage::RunRecord run;
  storage::ReportRecord a, b;  // counters only
  double change = 0.0;         // ChangeScore(a, b)
};

struct Comparison {
  Figures a, b;
  std::vector<std::pair<std::string, std::pair<std::optional<Figures>, std::optional<Figures>>>> by_firmware;
  std::vector<RunChange> most_changed;  // by change descending, then run id, robot id
  std::int64_t runs_compared = 0;       // runs with a report of both sets, of those scanned
  std::int64_t runs_changed = 0;        // of those, change > 0
  bool scan_truncated = false;          // more runs had both reports than kCompareScanLimit
};

/// How much a run's report changed between two parameter sets: Σ |b − a| over the hypothesis, view and
/// protrusion counts, plus 1 when started_localized differs — every count weighs the same, so a change of
/// start localization counts as one more or one fewer event (the contract of fleet.v1.RunComparison.change).
double ChangeScore(const storage::ReportRecord& a, const storage::ReportRecord& b);

struct JobsAnswer {
  std::vector<storage::JobRecord> jobs;                        // newest first
  std::vector<std::pair<std::string, std::int64_t>> analyses;  // upload analyses by state name
};

class FleetQueries {
 public:
  /// Runs compared one by one for "changed most" (keyset pages of the pairs' counters, no report bytes).
  static constexpr std::int64_t kCompareScanLimit = 5000;
  static constexpr int kConfusionRegionLimit = 200000;

  FleetQueries(storage::Repository& repository, std::string default_parameter_set);

  const std::string& default_parameter_set() const { return default_set_; }

  /// The filter as `caller` may see it: a robot's is pinned to itself (naming another robot finds nothing).
  storage::RunFilter Scoped(const Principal& caller, storage::RunFilter filter) const;

  storage::Result<StatisticsAnswer> Statistics(const Principal& caller, const storage::RunFilter& filter,
                                               std::optional<storage::GroupBy> group_by);
  storage::Result<MapsFigure> Maps(const Principal& caller, const storage::RunFilter& filter);
  storage::Result<ConfusionMatrix> Confusion(const Principal& caller, const std::string& parameter_set);
  storage::Result<RunsPage> Runs(const Principal& caller, RunsQuery query);
  /// NOT_FOUND naming `set_a`/`set_b` for an unknown set; `top` rows of most_changed (1..1000).
  storage::Result<Comparison> Compare(const Principal& caller, const storage::RunFilter& filter,
                                      const std::string& set_a, const std::string& set_b, std::size_t top);
  storage::Result<std::vector<storage::ProtrusionRegionRecord>> Labels(const Principal& caller,
                                                                       const std::string& parameter_set,
                                                                       int limit);
  /// Jobs of `kind` ("all": every kind), at most `limit`, newest first.
  storage::Result<JobsAnswer> Jobs(const Principal& caller, const std::string& kind, int limit);

  /// The run a request names (run_lookup.h's rules).
  storage::Result<storage::RunKey> Run(const Principal& caller, const std::string& robot_id,
                                       const std::string& run_id);
  /// The stored report with its regions' current labels; NOT_FOUND naming the run or the set.
  storage::Result<fleet::v1::RunReport> Report(const storage::RunKey& run, const std::string& parameter_set);

 private:
  storage::Repository& repository_;
  const std::string default_set_;
};

}  // namespace server
