#include "queries_handler.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "convert.h"
#include "run_lookup.h"

namespace server {
namespace {

// "<started_at_ms>:<run_id>/<robot_id>"; neither id may contain '/'. Tokens without "/<robot_id>" (from
// before run ids were per robot) still page correctly.
std::string EncodePageToken(const storage::RunCursor& cursor) {
  return std::to_string(cursor.started_at_ms) + ":" + cursor.run_id + "/" + cursor.robot_id;
}

storage::Result<storage::RunCursor> DecodePageToken(const std::string& token) {
  const std::size_t colon = token.find(':');
  storage::RunCursor cursor;
  try {
    if (colon == std::string::npos || colon == 0) throw std::invalid_argument("no colon");
    std::size_t used = 0;
    cursor.started_at_ms = std::stoll(token.substr(0, colon), &used);
    if (used != colon) throw std::invalid_argument("trailing characters");
  } catch (const std::exception&) {
    return storage::InvalidArgument("page_token: malformed; pass next_page_token from a previous response");
  }
  cursor.run_id = token.substr(colon + 1);
  if (const std::size_t slash = cursor.run_id.rfind('/'); slash != std::string::npos) {
    cursor.robot_id = cursor.run_id.substr(slash + 1);
    cursor.run_id.resize(slash);
  }
  if (cursor.run_id.empty()) return storage::InvalidArgument("page_token: malformed (no run id)");
  return cursor;
}

fleet::v1::ReportCounts Counts(const storage::ReportRecord& report) {
  fleet::v1::ReportCounts counts;
  counts.set_recovery_created(report.recovery_created);
  counts.set_recovery_accepted(report.recovery_accepted);
  counts.set_merge_created(report.merge_created);
  counts.set_merge_conditionally_accepted(report.merge_conditionally_accepted);
  counts.set_merge_conditional_then_rejected(report.merge_conditional_then_rejected);
  counts.set_views_ambiguous(report.views_ambiguous);
  counts.set_protrusions_found(report.protrusions_found);
  counts.set_started_localized(report.started_localized);
  counts.set_recovery_retracted(report.recovery_retracted);
  return counts;
}

double Change(const fleet::v1::ReportCounts& a, const fleet::v1::ReportCounts& b) {
  const auto d = [](std::int64_t x, std::int64_t y) { return static_cast<double>(std::llabs(x - y)); };
  return d(a.recovery_created(), b.recovery_created()) + d(a.recovery_accepted(), b.recovery_accepted()) +
         d(a.merge_created(), b.merge_created()) +
         d(a.merge_conditionally_accepted(), b.merge_conditionally_accepted()) +
         d(a.merge_conditional_then_rejected(), b.merge_conditional_then_rejected()) +
         d(a.views_ambiguous(), b.views_ambiguous()) + d(a.protrusions_found(), b.protrusions_found()) +
         d(a.recovery_retracted(), b.recovery_retracted()) +
         (a.started_localized() != b.started_localized() ? 1.0 : 0.0);
}

}  // namespace

grpc::Status QueriesHandler::GetRunReport(grpc::ServerContext* call, const fleet::v1::GetRunReportRequest* request,
                                          fleet::v1::GetRunReportResponse* response) {
  RpcScope scope(context_.metrics, "Queries/GetRunReport");
  return scope.Done(DoGetRunReport(call, request, response));
}

grpc::Status QueriesHandler::DoGetRunReport(grpc::ServerContext* call, const fleet::v1::GetRunReportRequest* request,
                                            fleet::v1::GetRunReportResponse* response) {
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) return denied;
  if (request->run_id().empty()) return InvalidArgument("run_id: required");
  const std::string set = request->parameter_set().empty() ? context_.default_parameter_set : request->parameter_set();
  auto key = ResolveRun(*context_.repository, principal, request->robot_id(), request->run_id());
  if (!key.ok()) return ToGrpc(key.status());
  auto report = context_.repository->GetReport(*key, set);
  if (!report.ok()) {
    if (report.status().code() != storage::StatusCode::kNotFound) return ToGrpc(report.status());
    auto run = context_.repository->GetRun(*key);
    if (!run.ok() && run.status().code() == storage::StatusCode::kNotFound) {
      return {grpc::StatusCode::NOT_FOUND, "run_id: no run \"" + request->run_id() + "\""};
    }
    return {grpc::StatusCode::NOT_FOUND, "parameter_set: run \"" + request->run_id() + "\" has no report for set \"" +
                                             set + "\" (yet: analysis may be queued)"};
  }
  fleet::v1::RunReport* out = response->mutable_report();
  if (!out->ParseFromString(report->report)) {
    return {grpc::StatusCode::DATA_LOSS, "stored report of run " + request->run_id() + " does not parse"};
  }
  auto regions = context_.repository->ListProtrusionRegions(*key, set);
  if (regions.ok()) {
    std::map<std::int64_t, std::string> labels;
    for (const auto& region : *regions) {
      if (region.label) labels[region.region_id] = *region.label;
    }
    for (auto& region : *out->mutable_protrusion_regions()) {
      auto it = labels.find(region.id());
      if (it != labels.end()) region.set_label(it->second);
    }
  }
  if (!request->include_rerun_child()) out->clear_rerun_child();
  return grpc::Status::OK;
}

grpc::Status QueriesHandler::ListRuns(grpc::ServerContext* call, const fleet::v1::ListRunsRequest* request,
                                      fleet::v1::ListRunsResponse* response) {
  RpcScope scope(context_.metrics, "Queries/ListRuns");
  return scope.Done(DoListRuns(call, request, response));
}

grpc::Status QueriesHandler::DoListRuns(grpc::ServerContext* call, const fleet::v1::ListRunsRequest* request,
                                        fleet::v1::ListRunsResponse* response) {
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) return denied;
  if (request->page_size() < 0 || request->page_size() > 1000) return InvalidArgument("page_size: expected 0..1000");
  const int page_size = request->page_size() == 0 ? 100 : request->page_size();
  auto filter = FromProto(request->filter(), "filter");
  if (!filter.ok()) return ToGrpc(filter.status());
  std::optional<storage::RunCursor> after;
  if (!request->page_token().empty()) {
    auto cursor = DecodePageToken(request->page_token());
    if (!cursor.ok()) return ToGrpc(cursor.status());
    after = *cursor;
  }
  auto page = context_.repository->ListRuns(*filter, page_size, after);
  if (!page.ok()) return ToGrpc(page.status());
  for (const auto& run : page->runs) {
    fleet::v1::RunSummary* summary = response->add_runs();
    summary->set_run_id(run.run_id);
    summary->set_robot_id(run.robot_id);
    summary->set_firmware(run.firmware);
    summary->set_robot_model(run.robot_model);
    summary->set_started_at(ToSeconds(run.started_at_ms));
    summary->set_ended_at(ToSeconds(run.ended_at_ms));
    summary->set_parent_snapshot_id(run.parent_snapshot_id.value_or(""));
    summary->set_child_snapshot_id(run.child_snapshot_id.value_or(""));
    summary->set_telemetry_bytes(run.telemetry_size);
    auto sets = context_.repository->ListReportParameterSets(run.key());
    if (sets.ok()) {
      for (const auto& set : *sets) summary->add_report_parameter_sets(set);
    }
  }
  if (page->next) response->set_next_page_token(EncodePageToken(*page->next));
  return grpc::Status::OK;
}

grpc::Status QueriesHandler::GetFleetStatistics(grpc::ServerContext* call,
                                                const fleet::v1::GetFleetStatisticsRequest* request,
                                                fleet::v1::GetFleetStatisticsResponse* response) {
  RpcScope scope(context_.metrics, "Queries/GetFleetStatistics");
  return scope.Done(DoStatistics(call, request, response));
}

grpc::Status QueriesHandler::DoStatistics(grpc::ServerContext* call, const fleet::v1::GetFleetStatisticsRequest* request,
                                          fleet::v1::GetFleetStatisticsResponse* response) {
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) return denied;
  auto filter = FromProto(request->filter(), "filter");
  if (!filter.ok()) return ToGrpc(filter.status());
  auto total = context_.repository->Aggregate(*filter);
  if (!total.ok()) return ToGrpc(total.status());
  *response->mutable_total() = ToProto(*total);
  std::optional<storage::GroupBy> group_by;
  switch (request->group_by()) {
    case fleet::v1::GROUP_BY_NONE: break;
    case fleet::v1::GROUP_BY_DAY: group_by = storage::GroupBy::kDay; break;
    case fleet::v1::GROUP_BY_FIRMWARE: group_by = storage::GroupBy::kFirmware; break;
    case fleet::v1::GROUP_BY_ROBOT_MODEL: group_by = storage::GroupBy::kRobotModel; break;
    case fleet::v1::GROUP_BY_PARAMETER_SET: group_by = storage::GroupBy::kParameterSet; break;
    case fleet::v1::GROUP_BY_ROBOT: group_by = storage::GroupBy::kRobot; break;
    default: return InvalidArgument("group_by: unknown value " + std::to_string(request->group_by()));
  }
  if (!group_by) return grpc::Status::OK;
  auto groups = context_.repository->AggregateBy(*filter, *group_by);
  if (!groups.ok()) return ToGrpc(groups.status());
  for (const auto& group : *groups) {
    fleet::v1::StatisticsGroup* out = response->add_groups();
    out->set_key(*group_by == storage::GroupBy::kDay ? DayKey(group.key) : group.key);
    *out->mutable_figures() = ToProto(group.statistics);
  }
  return grpc::Status::OK;
}

grpc::Status QueriesHandler::CompareParameterSets(grpc::ServerContext* call,
                                                  const fleet::v1::CompareParameterSetsRequest* request,
                                                  fleet::v1::CompareParameterSetsResponse* response) {
  RpcScope scope(context_.metrics, "Queries/CompareParameterSets");
  return scope.Done(DoCompare(call, request, response));
}

grpc::Status QueriesHandler::DoCompare(grpc::ServerContext* call, const fleet::v1::CompareParameterSetsRequest* request,
                                       fleet::v1::CompareParameterSetsResponse* response) {
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) return denied;
  if (request->set_a().empty()) return InvalidArgument("set_a: required");
  if (request->set_b().empty()) return InvalidArgument("set_b: required");
  if (request->top() < 0 || request->top() > 1000) return InvalidArgument("top: expected 0..1000");
  for (const auto& [field, name] : {std::pair{"set_a", request->set_a()}, std::pair{"set_b", request->set_b()}}) {
    auto stored = context_.repository->GetParameterSet(name);
    if (!stored.ok()) {
      if (stored.status().code() == storage::StatusCode::kNotFound) {
        return {grpc::StatusCode::NOT_FOUND, std::string(field) + ": no parameter set \"" + name + "\""};
      }
      return ToGrpc(stored.status());
    }
  }
  auto filter = FromProto(request->filter(), "filter");
  if (!filter.ok()) return ToGrpc(filter.status());
  storage::RunFilter filter_a = *filter, filter_b = *filter;
  filter_a.parameter_set = request->set_a();
  filter_b.parameter_set = request->set_b();
  auto a = context_.repository->Aggregate(filter_a);
  if (!a.ok()) return ToGrpc(a.status());
  auto b = context_.repository->Aggregate(filter_b);
  if (!b.ok()) return ToGrpc(b.status());
  *response->mutable_a() = ToProto(*a);
  *response->mutable_b() = ToProto(*b);
  *response->mutable_delta() = Delta(response->a(), response->b());

  const std::size_t top = request->top() == 0 ? 10 : static_cast<std::size_t>(request->top());
  std::vector<fleet::v1::RunComparison> comparisons;
  std::int64_t compared = 0, changed = 0;
  std::optional<storage::RunCursor> cursor;
  do {
    if (call->IsCancelled()) return {grpc::StatusCode::CANCELLED, "cancelled or deadline exceeded"};
    auto page = context_.repository->ListRuns(filter_a, 500, cursor);
    if (!page.ok()) return ToGrpc(page.status());
    for (const auto& run : page->runs) {
      auto report_b = context_.repository->GetReport(run.key(), request->set_b());
      if (!report_b.ok()) continue;
      auto report_a = context_.repository->GetReport(run.key(), request->set_a());
      if (!report_a.ok()) continue;
      ++compared;
      fleet::v1::RunComparison comparison;
      comparison.set_run_id(run.run_id);
      comparison.set_robot_id(run.robot_id);
      *comparison.mutable_a() = Counts(*report_a);
      *comparison.mutable_b() = Counts(*report_b);
      comparison.set_change(Change(comparison.a(), comparison.b()));
      if (comparison.change() > 0) ++changed;
      comparisons.push_back(std::move(comparison));
      // Keep memory bounded: trim to the best `top` now and then.
      if (comparisons.size() > 4 * top + 1000) {
        std::partial_sort(comparisons.begin(), comparisons.begin() + static_cast<std::ptrdiff_t>(top),
                          comparisons.end(), [](const auto& x, const auto& y) {
                            return x.change() != y.change() ? x.change() > y.change() : x.run_id() < y.run_id();
                          });
        comparisons.resize(top);
      }
    }
    cursor = page->next;
  } while (cursor);
  std::sort(comparisons.begin(), comparisons.end(), [](const auto& x, const auto& y) {
    return x.change() != y.change() ? x.change() > y.change() : x.run_id() < y.run_id();
  });
  if (comparisons.size() > top) comparisons.resize(top);
  response->set_runs_compared(compared);
  response->set_runs_changed(changed);
  for (auto& comparison : comparisons) *response->add_most_changed() = std::move(comparison);
  return grpc::Status::OK;
}

}  // namespace server
