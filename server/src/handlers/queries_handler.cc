#include "queries_handler.h"

#include "convert.h"

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

}  // namespace

grpc::Status QueriesHandler::GetRunReport(grpc::ServerContext* call,
                                          const fleet::v1::GetRunReportRequest* request,
                                          fleet::v1::GetRunReportResponse* response) {
  RpcScope scope(context_.metrics, "Queries/GetRunReport");
  return scope.Done(DoGetRunReport(call, request, response));
}

grpc::Status QueriesHandler::DoGetRunReport(grpc::ServerContext* call,
                                            const fleet::v1::GetRunReportRequest* request,
                                            fleet::v1::GetRunReportResponse* response) {
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok())
    return denied;
  if (request->run_id().empty()) return InvalidArgument("run_id: required");
  const std::string set =
      request->parameter_set().empty() ? context_.default_parameter_set : request->parameter_set();
  auto key = queries_.Run(principal, request->robot_id(), request->run_id());
  if (!key.ok()) return ToGrpc(key.status());
  auto report = queries_.Report(*key, set);
  if (!report.ok()) return ToGrpc(report.status());
  *response->mutable_report() = std::move(report).value();
  if (!request->include_rerun_child()) response->mutable_report()->clear_rerun_child();
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
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok())
    return denied;
  if (request->page_size() < 0 || request->page_size() > 1000)
    return InvalidArgument("page_size: expected 0..1000");
  const int page_size = request->page_size() == 0 ? 100 : request->page_size();
  auto filter = FromProto(request->filter(), "filter");
  if (!filter.ok()) return ToGrpc(filter.status());
  std::optional<storage::RunCursor> after;
  if (!request->page_token().empty()) {
    auto cursor = DecodePageToken(request->page_token());
    if (!cursor.ok()) return ToGrpc(cursor.status());
    after = *cursor;
  }
  RunsQuery query;
  query.filter = *filter;
  query.page_size = page_size;
  query.after = after;
  query.with_report_sets = true;
  auto page = queries_.Runs(principal, query);
  if (!page.ok()) return ToGrpc(page.status());
  for (const RunRow& row : page->rows) {
    const storage::RunRecord& run = row.run;
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
    for (const auto& set : row.report_sets) summary->add_report_parameter_sets(set);
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

grpc::Status QueriesHandler::DoStatistics(grpc::ServerContext* call,
                                          const fleet::v1::GetFleetStatisticsRequest* request,
                                          fleet::v1::GetFleetStatisticsResponse* response) {
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok())
    return denied;
  auto filter = FromProto(request->filter(), "filter");
  if (!filter.ok()) return ToGrpc(filter.status());
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
  auto answer = queries_.Statistics(principal, *filter, group_by);
  if (!answer.ok()) return ToGrpc(answer.status());
  *response->mutable_total() = ToProto(answer->total);
  for (const FiguresGroup& group : answer->groups) {
    fleet::v1::StatisticsGroup* out = response->add_groups();
    out->set_key(group.key);
    *out->mutable_figures() = ToProto(group.figures);
  }
  return grpc::Status::OK;
}

grpc::Status QueriesHandler::CompareParameterSets(grpc::ServerContext* call,
                                                  const fleet::v1::CompareParameterSetsRequest* request,
                                                  fleet::v1::CompareParameterSetsResponse* response) {
  RpcScope scope(context_.metrics, "Queries/CompareParameterSets");
  return scope.Done(DoCompare(call, request, response));
}

grpc::Status QueriesHandler::DoCompare(grpc::ServerContext* call,
                                       const fleet::v1::CompareParameterSetsRequest* request,
                                       fleet::v1::CompareParameterSetsResponse* response) {
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok())
    return denied;
  if (request->top() < 0 || request->top() > 1000) return InvalidArgument("top: expected 0..1000");
  auto filter = FromProto(request->filter(), "filter");
  if (!filter.ok()) return ToGrpc(filter.status());
  const std::size_t top = request->top() == 0 ? 10 : static_cast<std::size_t>(request->top());
  auto comparison = queries_.Compare(principal, *filter, request->set_a(), request->set_b(), top);
  if (!comparison.ok()) return ToGrpc(comparison.status());
  *response->mutable_a() = ToProto(comparison->a);
  *response->mutable_b() = ToProto(comparison->b);
  *response->mutable_delta() = Delta(response->a(), response->b());
  response->set_runs_compared(comparison->runs_compared);
  response->set_runs_changed(comparison->runs_changed);
  response->set_scan_truncated(comparison->scan_truncated);
  for (const RunChange& change : comparison->most_changed) {
    fleet::v1::RunComparison* out = response->add_most_changed();
    out->set_run_id(change.run.run_id);
    out->set_robot_id(change.run.robot_id);
    *out->mutable_a() = Counts(change.a);
    *out->mutable_b() = Counts(change.b);
    out->set_change(change.change);
  }
  return grpc::Status::OK;
}

}  // namespace server
