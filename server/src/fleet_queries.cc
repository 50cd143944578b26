#include "server/fleet_queries.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>

#include "run_lookup.h"
#include "server/jobs.h"

namespace server {
namespace {

std::optional<double> Ratio(std::int64_t numerator, std::int64_t denominator) {
  if (denominator <= 0) return std::nullopt;
  return static_cast<double>(numerator) / static_cast<double>(denominator);
}

bool Ranks(const RunChange& x, const RunChange& y) {
  if (x.change != y.change) return x.change > y.change;
  if (x.run.run_id != y.run.run_id) return x.run.run_id < y.run.run_id;
  return x.run.robot_id < y.run.robot_id;
}

}  // namespace

Figures FiguresOf(const storage::FleetStatistics& s) {
  Figures f;
  f.counts = s;
  f.recovery_per_run = Ratio(s.recovery_created, s.reports);
  f.recovery_accepted_share = Ratio(s.recovery_accepted, s.recovery_created);
  f.started_localized_share = Ratio(s.started_localized, s.reports);
  f.merge_conditional_then_rejected_share = Ratio(s.merge_conditional_then_rejected, s.merge_created);
  f.ambiguous_view_share = Ratio(s.views_ambiguous, s.views_total);
  f.protrusions_per_run = Ratio(s.protrusions_found, s.reports);
  f.recovery_retracted_share = Ratio(s.recovery_retracted, s.recovery_accepted);
  return f;
}

std::string DayKey(const std::string& days_since_epoch) {
  std::int64_t day = 0;
  std::size_t used = 0;
  try {
    day = std::stoll(days_since_epoch, &used);
  } catch (const std::exception&) {
    return days_since_epoch;
  }
  if (used != days_since_epoch.size()) return days_since_epoch;
  const std::chrono::year_month_day ymd{std::chrono::sys_days{std::chrono::days{day}}};
  char text[16];
  std::snprintf(text, sizeof text, "%04d-%02u-%02u", static_cast<int>(ymd.year()),
                static_cast<unsigned>(ymd.month()), static_cast<unsigned>(ymd.day()));
  return text;
}

double ChangeScore(const storage::ReportRecord& a, const storage::ReportRecord& b) {
  const auto d = [](std::int64_t x, std::int64_t y) { return static_cast<double>(std::llabs(x - y)); };
  return d(a.recovery_created, b.recovery_created) + d(a.recovery_accepted, b.recovery_accepted) +
         d(a.merge_created, b.merge_created) +
         d(a.merge_conditionally_accepted, b.merge_conditionally_accepted) +
         d(a.merge_conditional_then_rejected, b.merge_conditional_then_rejected) +
         d(a.views_ambiguous, b.views_ambiguous) + d(a.protrusions_found, b.protrusions_found) +
         d(a.recovery_retracted, b.recovery_retracted) +
         (a.started_localized != b.started_localized ? 1.0 : 0.0);
}

FleetQueries::FleetQueries(storage::Repository& repository, std::string default_parameter_set)
    : repository_(repository), default_set_(std::move(default_parameter_set)) {}

storage::RunFilter FleetQueries::Scoped(const Principal& caller, storage::RunFilter filter) const {
  if (caller.role != Role::kRobot) return filter;
  // Another robot's id finds nothing: an id that cannot be a robot's ("/" is outside the id syntax).
  filter.robot_id = filter.robot_id.empty() || filter.robot_id == caller.id ? caller.id : "/";
  return filter;
}

storage::Result<StatisticsAnswer> FleetQueries::Statistics(const Principal& caller,
                                                           const storage::RunFilter& filter,
                                                           std::optional<storage::GroupBy> group_by) {
  const storage::RunFilter scoped = Scoped(caller, filter);
  ASSIGN_OR_RETURN(auto total, repository_.Aggregate(scoped));
  StatisticsAnswer answer;
  answer.total = FiguresOf(total);
  if (!group_by) return answer;
  ASSIGN_OR_RETURN(auto groups, repository_.AggregateBy(scoped, *group_by));
  for (const auto& group : groups) {
    answer.groups.push_back(
        {*group_by == storage::GroupBy::kDay ? DayKey(group.key) : group.key, FiguresOf(group.statistics)});
  }
  return answer;
}

storage::Result<MapsFigure> FleetQueries::Maps(const Principal& caller, const storage::RunFilter& filter) {
  ASSIGN_OR_RETURN(auto robots, repository_.AggregateBy(Scoped(caller, filter), storage::GroupBy::kRobot));
  MapsFigure figure;
  for (const auto& group : robots) {
    const storage::FleetStatistics& s = group.statistics;
    if (s.views_total <= 0) continue;
    ++figure.maps;
    if (s.views_ambiguous > 0) ++figure.maps_with_ambiguous_views;
    const double share = static_cast<double>(s.views_ambiguous) / static_cast<double>(s.views_total);
    ++figure.ambiguous_share_histogram[static_cast<std::size_t>(
        std::clamp(static_cast<int>(share * 10.0), 0, 9))];
  }
  figure.share_with_ambiguous_views = Ratio(figure.maps_with_ambiguous_views, figure.maps);
  return figure;
}

storage::Result<ConfusionMatrix> FleetQueries::Confusion(const Principal& caller,
                                                         const std::string& parameter_set) {
  ASSIGN_OR_RETURN(auto labelled, Labels(caller, parameter_set, kConfusionRegionLimit));
  ConfusionMatrix m;
  for (const auto& region : labelled) {
    if (!region.label) continue;
    ++m.labelled;
    if (region.predicted_class != "protrusion" && region.predicted_class != "new_space") {
      ++m.unclassified;
      continue;
    }
    const bool truth = *region.label == "protrusion", predicted = region.predicted_class == "protrusion";
    ++(truth ? (predicted ? m.true_positive : m.false_negative)
             : (predicted ? m.false_positive : m.true_negative));
  }
  m.recall = Ratio(m.true_positive, m.true_positive + m.false_negative);
  m.precision = Ratio(m.true_positive, m.true_positive + m.false_positive);
  m.false_positive_rate = Ratio(m.false_positive, m.false_positive + m.true_negative);
  return m;
}

storage::Result<RunsPage> FleetQueries::Runs(const Principal& caller, RunsQuery query) {
  if (query.page_size < 1 || query.page_size > 1000)
    return storage::InvalidArgument("page_size: expected 1..1000");
  const storage::RunFilter filter = Scoped(caller, query.filter);
  RunsPage page;
  std::optional<storage::RunCursor> next = query.after;
  for (int pages = 0; pages < (query.only_with_regions ? 20 : 1); ++pages) {
    ASSIGN_OR_RETURN(auto runs, repository_.ListRuns(filter, query.page_size, next));
    next = runs.next;
    for (auto& run : runs.runs) {
      RunRow row;
      if (!query.report_set.empty()) {
        auto report = repository_.GetReport(run.key(), query.report_set);
        if (report.ok()) {
          row.report = std::move(report).value();
          row.report->report.clear();
        } else if (report.status().code() != storage::StatusCode::kNotFound) {
          return report.status();
        }
      }
      if (query.with_report_sets) {
        ASSIGN_OR_RETURN(auto sets, repository_.ListReportParameterSets(run.key()));
        row.report_sets = std::move(sets);
      }
      if (query.with_regions || query.only_with_regions) {
        ASSIGN_OR_RETURN(auto regions, repository_.ListProtrusionRegions(run.key(), query.report_set));
        row.regions = static_cast<std::int64_t>(regions.size());
        for (const auto& region : regions) row.regions_labelled += region.label ? 1 : 0;
      }
      if (query.only_with_regions && row.regions == 0) continue;
      row.run = std::move(run);
      page.rows.push_back(std::move(row));
      if (static_cast<int>(page.rows.size()) >= query.page_size) {
        const storage::RunRecord& last = page.rows.back().run;
        if (query.only_with_regions)
          next = storage::RunCursor{last.started_at_ms, last.run_id, last.robot_id};
        break;
      }
    }
    if (static_cast<int>(page.rows.size()) >= query.page_size || !next) break;
  }
  page.next = next;
  return page;
}

storage::Result<Comparison> FleetQueries::Compare(const Principal& caller, const storage::RunFilter& filter,
                                                  const std::string& set_a, const std::string& set_b,
                                                  std::size_t top) {
  if (set_a.empty()) return storage::InvalidArgument("set_a: required");
  if (set_b.empty()) return storage::InvalidArgument("set_b: required");
  if (top < 1 || top > 1000) return storage::InvalidArgument("top: expected 1..1000");
  for (const auto& [field, name] : {std::pair{"set_a", set_a}, std::pair{"set_b", set_b}}) {
    auto stored = repository_.GetParameterSet(name);
    if (!stored.ok() && stored.status().code() == storage::StatusCode::kNotFound) {
      return storage::NotFound(std::string(field) + ": no parameter set \"" + name + "\"");
    }
    RETURN_IF_ERROR(stored.status());
  }
  const storage::RunFilter scoped = Scoped(caller, filter);
  Comparison out;
  std::map<std::string, std::pair<std::optional<Figures>, std::optional<Figures>>> by_firmware;
  for (const auto& [set, figures, side] : {std::tuple{set_a, &out.a, 0}, std::tuple{set_b, &out.b, 1}}) {
    storage::RunFilter one = scoped;
    one.parameter_set = set;
    ASSIGN_OR_RETURN(auto total, repository_.Aggregate(one));
    *figures = FiguresOf(total);
    ASSIGN_OR_RETURN(auto groups, repository_.AggregateBy(one, storage::GroupBy::kFirmware));
    for (const auto& group : groups) {
      (side == 0 ? by_firmware[group.key].first : by_firmware[group.key].second) =
          FiguresOf(group.statistics);
    }
  }
  out.by_firmware.assign(by_firmware.begin(), by_firmware.end());

  // A set with few reports in the slice (a candidate tried on part of the fleet) is walked itself: walking
  // the slice's runs for its pairs would cost the whole slice. Two sets that both cover the slice are
  // walked by run, which finds a pair at nearly every step.
  const std::int64_t reports_a = out.a.counts.reports, reports_b = out.b.counts.reports;
  storage::ReportPairScan scan = storage::ReportPairScan::kRunsInStartOrder;
  if (std::min(reports_a, reports_b) <= kCompareScanLimit) {
    scan = reports_a <= reports_b ? storage::ReportPairScan::kReportsOfSetA
                                  : storage::ReportPairScan::kReportsOfSetB;
  }
  std::optional<storage::RunCursor> after;
  do {
    ASSIGN_OR_RETURN(auto page, repository_.ListReportPairs(scoped, set_a, set_b, 1000, after, scan));
    for (auto& pair : page.pairs) {
      if (out.runs_compared >= kCompareScanLimit) {
        out.scan_truncated = true;
        break;
      }
      ++out.runs_compared;
      RunChange change{std::move(pair.run), std::move(pair.a), std::move(pair.b), 0.0};
      change.change = ChangeScore(change.a, change.b);
      if (change.change > 0) ++out.runs_changed;
      out.most_changed.push_back(std::move(change));
    }
    after = out.scan_truncated ? std::nullopt : page.next;
  } while (after);
  const std::size_t keep = std::min(top, out.most_changed.size());
  std::partial_sort(out.most_changed.begin(), out.most_changed.begin() + static_cast<std::ptrdiff_t>(keep),
                    out.most_changed.end(), Ranks);
  out.most_changed.resize(keep);
  return out;
}

storage::Result<std::vector<storage::ProtrusionRegionRecord>> FleetQueries::Labels(
    const Principal& caller, const std::string& parameter_set, int limit) {
  auto regions = repository_.ListLabelledRegions(parameter_set, limit);
  if (!regions.ok() || caller.role != Role::kRobot) return regions;
  std::erase_if(*regions, [&caller](const auto& region) { return region.robot_id != caller.id; });
  return regions;
}

storage::Result<JobsAnswer> FleetQueries::Jobs(const Principal& caller, const std::string& kind, int limit) {
  if (limit < 1 || limit > 1000) return storage::InvalidArgument("limit: expected 1..1000");
  // Storage lists by id ascending; newest first is what people want, so keep the tail. Retention bounds the
  // table (--retain-jobs-days).
  ASSIGN_OR_RETURN(auto jobs, repository_.ListJobs(std::nullopt, 1000000));
  JobsAnswer answer;
  std::map<std::string, std::int64_t> analyses;
  for (auto it = jobs.rbegin(); it != jobs.rend(); ++it) {
    if (caller.role == Role::kRobot && it->robot_id != caller.id) continue;
    if (it->kind == kAnalyzeRunJob && !it->parent_job_id) ++analyses[std::string(storage::Name(it->state))];
    if (kind != "all" && it->kind != kind) continue;
    if (static_cast<int>(answer.jobs.size()) < limit) answer.jobs.push_back(*it);
  }
  answer.analyses.assign(analyses.begin(), analyses.end());
  return answer;
}

storage::Result<storage::RunKey> FleetQueries::Run(const Principal& caller, const std::string& robot_id,
                                                   const std::string& run_id) {
  return ResolveRun(repository_, caller, robot_id, run_id);
}

storage::Result<fleet::v1::RunReport> FleetQueries::Report(const storage::RunKey& run,
                                                           const std::string& parameter_set) {
  auto stored = repository_.GetReport(run, parameter_set);
  if (!stored.ok()) {
    if (stored.status().code() != storage::StatusCode::kNotFound) return stored.status();
    auto exists = repository_.GetRun(run);
    if (!exists.ok() && exists.status().code() == storage::StatusCode::kNotFound) {
      return storage::NotFound("run_id: no run \"" + run.run_id + "\"");
    }
    return storage::NotFound("parameter_set: run \"" + run.run_id + "\" has no report with parameter set \"" +
                             parameter_set + "\" (yet: analysis may be queued)");
  }
  fleet::v1::RunReport report;
  if (!report.ParseFromString(stored->report)) {
    return storage::DataLoss("stored report of run " + run.run_id + " does not parse");
  }
  ASSIGN_OR_RETURN(auto regions, repository_.ListProtrusionRegions(run, parameter_set));
  std::map<std::int64_t, std::string> labels;
  for (const auto& region : regions) {
    if (region.label) labels[region.region_id] = *region.label;
  }
  for (auto& region : *report.mutable_protrusion_regions()) {
    if (const auto it = labels.find(region.id()); it != labels.end()) region.set_label(it->second);
  }
  return report;
}

}  // namespace server
