#include "server/dashboard_routes.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <unordered_map>

#include "dashboard_maps.h"
#include "http_helpers.h"
#include "render_cache.h"
#include "run_lookup.h"
#include "fleet/v1/report.pb.h"
#include "server/jobs.h"
#include "server/log.h"

#ifndef FLEETD_WEB_DIR_DEFAULT
#define FLEETD_WEB_DIR_DEFAULT ""
#endif

namespace server {
namespace {

using json = nlohmann::json;
using http::Error;
using http::Json;
using http::ParseInt;
using http::ParseQuery;
using http::SplitPath;

constexpr int kMaxPageSize = 200;
constexpr int kCompareScanLimit = 2000;  // runs compared one by one for "changed most"
constexpr int kConfusionRegionLimit = 200000;

// ---- HTTP helpers ---------------------------------------------------------------------------------------

/// Reads an integer parameter; `error` gets a message naming it when it is malformed or out of range.
std::optional<std::int64_t> IntParam(const std::map<std::string, std::string>& params, const std::string& name,
                                     std::int64_t low, std::int64_t high, std::string* error) {
  const auto it = params.find(name);
  if (it == params.end() || it->second.empty()) return std::nullopt;
  const auto value = ParseInt(it->second);
  if (!value || *value < low || *value > high) {
    *error = name + ": expected an integer in [" + std::to_string(low) + ", " + std::to_string(high) + "], got \"" +
             it->second + "\"";
    return std::nullopt;
  }
  return value;
}

std::string Param(const std::map<std::string, std::string>& params, const std::string& name) {
  const auto it = params.find(name);
  return it == params.end() ? std::string() : it->second;
}

// ---- JSON of storage records -----------------------------------------------------------------------------

json Ratio(std::int64_t numerator, std::int64_t denominator) {
  if (denominator <= 0) return nullptr;
  return static_cast<double>(numerator) / static_cast<double>(denominator);
}

/// The counters and the paper's figures derived from them (null when the denominator is 0).
json StatisticsJson(const storage::FleetStatistics& s) {
  return json{
      {"reports", s.reports},
      {"robots", s.robots},
      {"recovery_created", s.recovery_created},
      {"recovery_accepted", s.recovery_accepted},
      {"merge_created", s.merge_created},
      {"merge_conditionally_accepted", s.merge_conditionally_accepted},
      {"merge_conditional_then_rejected", s.merge_conditional_then_rejected},
      {"views_total", s.views_total},
      {"views_ambiguous", s.views_ambiguous},
      {"started_localized", s.started_localized},
      {"protrusions_found", s.protrusions_found},
      {"recovery_retracted", s.recovery_retracted},
      // Fig. 6: recovery hypotheses per run and the share accepted.
      {"recovery_per_run", Ratio(s.recovery_created, s.reports)},
      {"recovery_accepted_share", Ratio(s.recovery_accepted, s.recovery_created)},
      // Fig. 7: runs started localized; merge hypotheses conditionally accepted, then rejected.
      {"started_localized_share", Ratio(s.started_localized, s.reports)},
      {"merge_conditional_then_rejected_share", Ratio(s.merge_conditional_then_rejected, s.merge_created)},
      // Fig. 8: ambiguous views as a share of views.
      {"ambiguous_view_share", Ratio(s.views_ambiguous, s.views_total)},
      // Fig. 12: protrusions found per map (run).
      {"protrusions_per_run", Ratio(s.protrusions_found, s.reports)},
      // Accepted recovery hypotheses the Mapper took back when later evidence contradicted them.
      {"recovery_retracted_share", Ratio(s.recovery_retracted, s.recovery_accepted)},
  };
}

std::string DayString(const std::string& key) {
  const auto day = ParseInt(key);
  if (!day) return key;
  const std::chrono::sys_days date{std::chrono::days{*day}};
  const std::chrono::year_month_day ymd{date};
  char text[16];
  std::snprintf(text, sizeof text, "%04d-%02u-%02u", static_cast<int>(ymd.year()), static_cast<unsigned>(ymd.month()),
                static_cast<unsigned>(ymd.day()));
  return text;
}

json RunJson(const storage::RunRecord& run) {
  return json{{"run_id", run.run_id},
              {"robot_id", run.robot_id},
              {"firmware", run.firmware},
              {"robot_model", run.robot_model},
              {"started_at_ms", run.started_at_ms},
              {"ended_at_ms", run.ended_at_ms},
              {"parent_snapshot_id", run.parent_snapshot_id ? json(*run.parent_snapshot_id) : json(nullptr)},
              {"child_snapshot_id", run.child_snapshot_id ? json(*run.child_snapshot_id) : json(nullptr)},
              {"telemetry_size", run.telemetry_size},
              {"telemetry_pruned_at_ms",
               run.telemetry_pruned_at_ms ? json(*run.telemetry_pruned_at_ms) : json(nullptr)}};
}

json ReportCountersJson(const storage::ReportRecord& report) {
  return json{{"parameter_set", report.parameter_set},
              {"recovery_created", report.recovery_created},
              {"recovery_accepted", report.recovery_accepted},
              {"recovery_retracted", report.recovery_retracted},
              {"merge_created", report.merge_created},
              {"merge_conditionally_accepted", report.merge_conditionally_accepted},
              {"merge_conditional_then_rejected", report.merge_conditional_then_rejected},
              {"views_total", report.views_total},
              {"views_ambiguous", report.views_ambiguous},
              {"started_localized", report.started_localized},
              {"protrusions_found", report.protrusions_found}};
}

json RegionJson(const storage::ProtrusionRegionRecord& region) {
  json features = json::object();
  if (!region.features_json.empty()) {
    features = json::parse(region.features_json, nullptr, /*allow_exceptions=*/false);
    if (features.is_discarded()) features = json::object();
  }
  return json{{"run_id", region.run_id},
              {"robot_id", region.robot_id},
              {"parameter_set", region.parameter_set},
              {"region_id", region.region_id},
              // x, y, width, height in child image cells (y down), as the map images are drawn.
              {"bbox", {region.bbox.min_x, region.bbox.min_y, region.bbox.max_x - region.bbox.min_x,
                        region.bbox.max_y - region.bbox.min_y}},
              {"features", features},
              {"predicted_class", region.predicted_class},
              {"probability", region.probability},
              {"label", region.label ? json(*region.label) : json(nullptr)},
              {"labelled_by", region.labelled_by ? json(*region.labelled_by) : json(nullptr)}};
}

json JobJson(const storage::JobRecord& job) {
  json out{{"job_id", job.job_id},
           {"kind", job.kind},
           {"state", storage::JobStateName(job.state)},
           {"attempts", job.attempts},
           {"max_attempts", job.max_attempts},
           {"progress_done", job.progress_done},
           {"progress_total", job.progress_total},
           {"last_error", job.last_error},
           {"created_at_ms", job.created_at_ms},
           {"updated_at_ms", job.updated_at_ms},
           {"parent_job_id", job.parent_job_id ? json(*job.parent_job_id) : json(nullptr)},
           {"lease_owner", job.lease_owner ? json(*job.lease_owner) : json(nullptr)},
           {"robot_id", job.robot_id ? json(*job.robot_id) : json(nullptr)}};
  if (job.kind == kReprocessJob) {
    if (auto payload = DecodeReprocessPayload(job.payload); payload.ok()) {
      out["parameter_set"] = payload->parameter_set;
      out["filter"] = json{{"robot_id", payload->filter.robot_id}, {"firmware", payload->filter.firmware}};
    }
  } else if (job.kind == kAnalyzeRunJob) {
    if (auto payload = DecodeAnalyzePayload(job.payload); payload.ok()) {
      out["parameter_set"] = payload->parameter_set;
      out["run_id"] = payload->run_id;
    }
  }
  return out;
}

// ---- Static files ----------------------------------------------------------------------------------------

std::string ContentTypeOf(const std::string& path) {
  static const std::map<std::string, std::string> kTypes = {
      {".html", "text/html; charset=utf-8"}, {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"}, {".css", "text/css; charset=utf-8"},
      {".json", "application/json"}, {".png", "image/png"}, {".svg", "image/svg+xml"},
      {".map", "application/json"}, {".ico", "image/x-icon"}};
  const std::string extension = std::filesystem::path(path).extension().string();
  const auto it = kTypes.find(extension);
  return it == kTypes.end() ? "application/octet-stream" : it->second;
}

/// Only plain relative paths: no "..", no empty or hidden segments, a conservative character set.
bool SafeRelativePath(const std::string& path) {
  if (path.empty() || path.size() > 256) return false;
  for (const std::string& part : SplitPath(path)) {
    if (part.empty() || part[0] == '.') return false;
  }
  return std::all_of(path.begin(), path.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
           c == '-' || c == '/';
  });
}

HttpResponse ServeFile(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in || std::filesystem::is_directory(file)) return Error(404, "not found");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  HttpResponse response;
  response.content_type = ContentTypeOf(file.string());
  response.body = bytes.str();
  response.headers.emplace_back("Cache-Control", "no-cache");
  return response;
}

std::filesystem::path ResolveWebDir() {
  if (const char* env = std::getenv("FLEETD_WEB_DIR"); env != nullptr && *env != '\0') return env;
  const std::filesystem::path built = FLEETD_WEB_DIR_DEFAULT;
  std::error_code ec;
  if (!built.empty() && std::filesystem::exists(built / "index.html", ec)) return built;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path("web") : exe.parent_path() / "web";
}

// ---- The routes ------------------------------------------------------------------------------------------

class Dashboard {
 public:
  Dashboard(storage::Repository& repository, Authenticator& authenticator, const FleetdConfig& config)
      : repository_(repository),
        authenticator_(authenticator),
        default_set_(config.default_parameter_set),
        web_dir_(ResolveWebDir()),
        label_limiter_(config.rate_limit_per_second, config.rate_limit_burst) {
    log::Info("dashboard_web_dir", {{"path", web_dir_.string()},
                                    {"found", std::filesystem::exists(web_dir_ / "index.html")}});
  }

  HttpResponse Static(const HttpRequest& request) {
    if (request.path == "/" || request.path == "/index.html") return ServeFile(web_dir_ / "index.html");
    const std::string prefix = "/static/";
    if (request.path.rfind(prefix, 0) != 0) return Error(404, "not found: " + request.path);
    const std::string relative = request.path.substr(prefix.size());
    if (!SafeRelativePath(relative)) return Error(404, "not found");
    const std::string vendor = "vendor/chart.js/";
    if (relative.rfind(vendor, 0) == 0) {
      return ServeFile(web_dir_ / "node_modules" / "chart.js" / "dist" / relative.substr(vendor.size()));
    }
    if (relative.rfind("node_modules", 0) == 0) return Error(404, "not found");
    return ServeFile(web_dir_ / relative);
  }

  HttpResponse Api(const HttpRequest& request) {
    const std::vector<std::string> parts = SplitPath(request.path);  // "api", ...
    const auto params = ParseQuery(request.query);
    if (parts.size() == 2 && parts[1] == "meta") return Meta();
    if (parts.size() == 2 && parts[1] == "stats") return Stats(params);
    if (parts.size() == 2 && parts[1] == "runs") return Runs(params);
    if (parts.size() >= 3 && parts.size() <= 5 && parts[1] == "runs") {
      auto run = RunOf(request, parts[2], params);
      if (!run.ok()) return Error(run.status());
      if (parts.size() == 3) return Run(*run, params);
      if (parts.size() == 4 && parts[3] == "graph") return Graph(*run, params);
      if (parts.size() == 5 && parts[3] == "map") return MapImage(*run, parts[4], params);
    }
    if (parts.size() == 2 && parts[1] == "labels") return Labels(params);
    if (parts.size() == 2 && parts[1] == "compare") return Compare(params);
    if (parts.size() == 2 && parts[1] == "jobs") return Jobs(params);
    return Error(404, "no such endpoint: " + request.path);
  }

  /// POST /api/runs/<id>/regions/<region>/label
  HttpResponse Label(const HttpRequest& request) {
    const std::vector<std::string> parts = SplitPath(request.path);
    if (parts.size() != 6 || parts[1] != "runs" || parts[3] != "regions" || parts[5] != "label") {
      return Error(404, "no such endpoint: POST " + request.path);
    }
    HttpResponse refusal;
    const std::optional<Principal> principal =
        http::AuthorizeRequest(authenticator_, request, Permission::kLabel, "labelling", &refusal);
    if (!principal) return refusal;
    if (!label_limiter_.Allow(principal->name)) return Error(429, "rate limit exceeded; retry later");
    const auto region_id = ParseInt(parts[4]);
    if (!region_id || *region_id < 0) return Error(400, "region: expected a non-negative integer, got \"" + parts[4] + "\"");
    const json body = json::parse(request.body, nullptr, /*allow_exceptions=*/false);
    if (body.is_discarded() || !body.is_object()) return Error(400, "body: expected a JSON object");
    const std::string label = body.value("label", "");
    if (label != "protrusion" && label != "new_space") {
      return Error(400, "label: expected \"protrusion\" or \"new_space\", got \"" + label + "\"");
    }
    std::string set = body.value("parameter_set", "");
    if (set.empty()) set = default_set_;
    auto run = ResolveRun(repository_, *principal, Param(ParseQuery(request.query), "robot"), parts[2]);
    if (!run.ok()) return Error(run.status());
    storage::Status labelled = repository_.LabelProtrusionRegion(*run, set, *region_id, label, principal->name);
    if (!labelled.ok()) {
      if (labelled.code() == storage::StatusCode::kNotFound) {
        return Error(404, "run \"" + parts[2] + "\" has no region " + parts[4] + " with parameter set \"" + set + "\"");
      }
      return Error(labelled);
    }
    log::Info("region_labelled", {{"run_id", parts[2]},
                                  {"robot_id", run->robot_id},
                                  {"region", static_cast<long long>(*region_id)},
                                  {"label", label},
                                  {"principal", principal->name},
                                  {"via", "dashboard"}});
    auto regions = repository_.ListProtrusionRegions(*run, set);
    if (!regions.ok()) return Error(regions.status());
    for (const auto& region : *regions) {
      if (region.region_id == *region_id) return Json(RegionJson(region));
    }
    return Error(404, "region vanished");
  }

 private:
  /// The run a /api/runs/<id> route names (?robot= picks among robots that share a run id; a robot reads its own).
  storage::Result<storage::RunKey> RunOf(const HttpRequest& request, const std::string& run_id,
                                         const std::map<std::string, std::string>& params) {
    const auto header = request.headers.find("authorization");
    const Authenticator::Verdict verdict =
        authenticator_.Authenticate(header == request.headers.end() ? "" : header->second, request.peer);
    if (verdict.outcome != Authenticator::Outcome::kOk) return storage::Unavailable(verdict.message);
    return ResolveRun(repository_, verdict.principal, Param(params, "robot"), run_id);
  }

  std::string SetOf(const std::map<std::string, std::string>& params) const {
    const std::string set = Param(params, "parameter_set");
    return set.empty() ? default_set_ : set;
  }

  /// The filter from ?firmware=&robot=&model=&parameter_set=&from_ms=&to_ms=.
  std::optional<storage::RunFilter> FilterOf(const std::map<std::string, std::string>& params, std::string* error) {
    storage::RunFilter filter;
    filter.firmware = Param(params, "firmware");
    filter.robot_id = Param(params, "robot");
    filter.robot_model = Param(params, "model");
    filter.parameter_set = Param(params, "parameter_set");
    filter.started_from_ms = IntParam(params, "from_ms", 0, 1LL << 53, error);
    filter.started_before_ms = IntParam(params, "to_ms", 0, 1LL << 53, error);
    if (!error->empty()) return std::nullopt;
    return filter;
  }

  HttpResponse Meta() {
    auto sets = repository_.ListParameterSetNames();
    if (!sets.ok()) return Error(sets.status());
    auto firmware = repository_.AggregateBy(storage::RunFilter{}, storage::GroupBy::kFirmware);
    if (!firmware.ok()) return Error(firmware.status());
    json firmware_keys = json::array();
    for (const auto& group : *firmware) firmware_keys.push_back(group.key);
    return Json(json{{"parameter_sets", *sets}, {"firmware", firmware_keys}, {"default_parameter_set", default_set_}});
  }

  HttpResponse Stats(const std::map<std::string, std::string>& params) {
    std::string error;
    auto filter = FilterOf(params, &error);
    if (!filter) return Error(400, error);
    if (filter->parameter_set.empty()) filter->parameter_set = default_set_;  // a run counts once
    auto total = repository_.Aggregate(*filter);
    if (!total.ok()) return Error(total.status());
    json out{{"parameter_set", filter->parameter_set}, {"total", StatisticsJson(*total)}};
    for (const auto& [name, group_by] : {std::pair{"by_day", storage::GroupBy::kDay},
                                         std::pair{"by_firmware", storage::GroupBy::kFirmware}}) {
      auto groups = repository_.AggregateBy(*filter, group_by);
      if (!groups.ok()) return Error(groups.status());
      json rows = json::array();
      for (const auto& group : *groups) {
        json row = StatisticsJson(group.statistics);
        row["key"] = group_by == storage::GroupBy::kDay ? DayString(group.key) : group.key;
        rows.push_back(std::move(row));
      }
      out[name] = std::move(rows);
    }
    // Fig. 8 counts maps: a robot's lifelong map is one map, so group by robot and count those with
    // ambiguous views, with each map's share of ambiguous views as a histogram (10 bins).
    auto robots = repository_.AggregateBy(*filter, storage::GroupBy::kRobot);
    if (!robots.ok()) return Error(robots.status());
    std::int64_t maps = 0, maps_with_ambiguous = 0;
    std::vector<std::int64_t> histogram(10, 0);
    for (const auto& group : *robots) {
      if (group.statistics.views_total <= 0) continue;
      ++maps;
      if (group.statistics.views_ambiguous > 0) ++maps_with_ambiguous;
      const double share = static_cast<double>(group.statistics.views_ambiguous) /
                           static_cast<double>(group.statistics.views_total);
      ++histogram[static_cast<std::size_t>(std::clamp(static_cast<int>(share * 10.0), 0, 9))];
    }
    out["maps"] = json{{"maps", maps},
                       {"maps_with_ambiguous_views", maps_with_ambiguous},
                       {"share_with_ambiguous_views", Ratio(maps_with_ambiguous, maps)},
                       {"ambiguous_share_histogram", histogram}};
    // Fig. 12: the classifier's predictions against engineers' labels (all labelled regions of the set).
    auto labelled = repository_.ListLabelledRegions(filter->parameter_set, kConfusionRegionLimit);
    if (!labelled.ok()) return Error(labelled.status());
    std::int64_t tp = 0, fp = 0, fn = 0, tn = 0, unclassified = 0;
    for (const auto& region : *labelled) {
      if (!region.label) continue;
      const bool truth = *region.label == "protrusion";
      if (region.predicted_class != "protrusion" && region.predicted_class != "new_space") {
        ++unclassified;
        continue;
      }
      const bool predicted = region.predicted_class == "protrusion";
      (truth ? (predicted ? tp : fn) : (predicted ? fp : tn)) += 1;
    }
    out["confusion"] = json{{"true_positive", tp},   {"false_positive", fp},
                            {"false_negative", fn},  {"true_negative", tn},
                            {"unclassified", unclassified}, {"labelled", labelled->size()},
                            {"recall", Ratio(tp, tp + fn)}, {"precision", Ratio(tp, tp + fp)},
                            {"false_positive_rate", Ratio(fp, fp + tn)}};
    return Json(out);
  }

  HttpResponse Runs(const std::map<std::string, std::string>& params) {
    std::string error;
    auto filter = FilterOf(params, &error);
    const auto limit = IntParam(params, "limit", 1, kMaxPageSize, &error);
    const auto after_ms = IntParam(params, "after_ms", 0, 1LL << 53, &error);
    if (!filter || !error.empty()) return Error(400, error);
    const std::string set = SetOf(params);
    std::optional<storage::RunCursor> after;
    if (after_ms) after = storage::RunCursor{*after_ms, Param(params, "after_id"), Param(params, "after_robot")};
    const bool with_regions_only = Param(params, "with_regions") == "1";
    const int page_size = static_cast<int>(limit.value_or(50));
    json runs = json::array();
    std::optional<storage::RunCursor> next = after;
    // with_regions: keep reading pages until this one is full, at most 20 pages per request.
    for (int pages = 0; pages < (with_regions_only ? 20 : 1); ++pages) {
      auto page = repository_.ListRuns(*filter, page_size, next);
      if (!page.ok()) return Error(page.status());
      next = page->next;
      for (const auto& run : page->runs) {
        json row = RunJson(run);
        auto report = repository_.GetReport(run.key(), set);
        if (report.ok()) {
          row["report"] = ReportCountersJson(*report);
        } else if (report.status().code() == storage::StatusCode::kNotFound) {
          row["report"] = nullptr;
        } else {
          return Error(report.status());
        }
        auto regions = repository_.ListProtrusionRegions(run.key(), set);
        std::int64_t labelled = 0;
        if (regions.ok()) {
          for (const auto& region : *regions) labelled += region.label ? 1 : 0;
        }
        row["regions"] = regions.ok() ? static_cast<std::int64_t>(regions->size()) : 0;
        row["regions_labelled"] = labelled;
        if (with_regions_only && row["regions"].get<std::int64_t>() == 0) continue;
        runs.push_back(std::move(row));
        if (static_cast<int>(runs.size()) >= page_size) {
          next = storage::RunCursor{run.started_at_ms, run.run_id, run.robot_id};
          break;
        }
      }
      if (static_cast<int>(runs.size()) >= page_size || !next) break;
    }
    json out{{"parameter_set", set}, {"runs", runs}, {"next", nullptr}};
    if (next) {
      out["next"] =
          json{{"after_ms", next->started_at_ms}, {"after_id", next->run_id}, {"after_robot", next->robot_id}};
    }
    return Json(out);
  }

  /// The stored report of a run as a proto (NOT_FOUND naming the set when there is none).
  storage::Result<fleet::v1::RunReport> LoadReport(const storage::RunKey& run, const std::string& set) {
    const std::string& run_id = run.run_id;
    auto stored = repository_.GetReport(run, set);
    if (!stored.ok()) {
      if (stored.status().code() == storage::StatusCode::kNotFound) {
        return storage::NotFound("run \"" + run_id + "\" has no report with parameter set \"" + set +
                                 "\" (yet: analysis may still be running)");
      }
      return stored.status();
    }
    fleet::v1::RunReport report;
    if (!report.ParseFromString(stored->report)) return storage::DataLoss("report of run " + run_id + " does not parse");
    return report;
  }

  HttpResponse Run(const storage::RunKey& key, const std::map<std::string, std::string>& params) {
    auto run = repository_.GetRun(key);
    if (!run.ok()) return Error(run.status());
    const std::string set = SetOf(params);
    json out{{"run", RunJson(*run)}, {"parameter_set", set}};
    auto sets = repository_.ListReportParameterSets(key);
    if (!sets.ok()) return Error(sets.status());
    out["report_parameter_sets"] = *sets;
    auto stored = repository_.GetReport(key, set);
    if (!stored.ok()) {
      if (stored.status().code() != storage::StatusCode::kNotFound) return Error(stored.status());
      out["report"] = nullptr;
      return Json(out);
    }
    out["report"] = ReportCountersJson(*stored);
    fleet::v1::RunReport report;
    if (report.ParseFromString(stored->report)) {
      const auto& d = report.divergence();
      out["analysis"] = json{
          {"map_version", report.map_version()},
          {"seconds_to_conditional_relocalization", report.seconds_to_conditional_relocalization()},
          {"seconds_to_full_relocalization", report.seconds_to_full_relocalization()},
          {"replay_seconds", report.replay_seconds()},
          {"detection_seconds", report.detection_seconds()},
          {"feature_names", std::vector<std::string>(report.feature_names().begin(), report.feature_names().end())},
          {"divergence", {{"robot_nodes", d.robot_nodes()}, {"rerun_nodes", d.rerun_nodes()},
                          {"robot_observation_edges", d.robot_observation_edges()},
                          {"rerun_observation_edges", d.rerun_observation_edges()},
                          {"node_position_rms", d.node_position_rms()}}},
          {"counts", {{"direct_edges", report.counts().direct_edges()},
                      {"recovery_expired", report.counts().recovery_expired()},
                      {"recovery_rejected", report.counts().recovery_rejected()},
                      {"merge_accepted", report.counts().merge_accepted()},
                      {"merge_expired", report.counts().merge_expired()},
                      {"merge_rejected", report.counts().merge_rejected()},
                      {"components_created", report.counts().components_created()}}}};
      if (report.has_ground_truth()) {
        const auto& g = report.ground_truth();
        out["analysis"]["ground_truth"] = {{"trajectory_rmse", g.trajectory_rmse()},
                                           {"wrong_observations", g.wrong_observations()},
                                           {"wrong_observations_accepted", g.wrong_observations_accepted()},
                                           {"correct_observations", g.correct_observations()},
                                           {"correct_observations_accepted", g.correct_observations_accepted()}};
      }
    }
    auto decisions = repository_.ListDecisions(key, set);
    if (!decisions.ok()) return Error(decisions.status());
    json timeline = json::array();
    for (const auto& decision : *decisions) {
      timeline.push_back({{"sequence", decision.sequence}, {"time_s", decision.time_s}, {"kind", decision.kind},
                          {"outcome", decision.outcome}, {"subject_id", decision.subject_id},
                          {"detail", decision.detail}});
    }
    out["decisions"] = std::move(timeline);
    auto ambiguous = repository_.ListAmbiguousViews(key, set);
    if (!ambiguous.ok()) return Error(ambiguous.status());
    json views = json::array();
    for (const auto& view : *ambiguous) views.push_back({{"view_id", view.view_id}, {"time_s", view.time_s}});
    out["ambiguous_views"] = std::move(views);
    auto regions = repository_.ListProtrusionRegions(key, set);
    if (!regions.ok()) return Error(regions.status());
    json region_rows = json::array();
    for (const auto& region : *regions) region_rows.push_back(RegionJson(region));
    out["regions"] = std::move(region_rows);
    return Json(out);
  }

  /// The rerun child's pose graph, with components (union-find over all edges) and the hypotheses' edges
  /// taken from the decisions: every observation that created or joined a hypothesis, marked with how the
  /// hypothesis ended (accepted, conditionally accepted then rejected, expired, ...).
  HttpResponse Graph(const storage::RunKey& run, const std::map<std::string, std::string>& params) {
    const std::string& run_id = run.run_id;
    auto report = LoadReport(run, SetOf(params));
    if (!report.ok()) return Error(report.status());
    const fleet::v1::MapSnapshot& map = report->rerun_child();
    std::unordered_map<std::int64_t, std::size_t> index;
    std::vector<std::size_t> parent(static_cast<std::size_t>(map.nodes_size()));
    for (int i = 0; i < map.nodes_size(); ++i) {
      index[map.nodes(i).id()] = static_cast<std::size_t>(i);
      parent[static_cast<std::size_t>(i)] = static_cast<std::size_t>(i);
    }
    auto find = [&parent](std::size_t i) {
      while (parent[i] != i) i = parent[i] = parent[parent[i]];
      return i;
    };
    json edges = json::array();
    for (const auto& edge : map.edges()) {
      const auto from = index.find(edge.from()), to = index.find(edge.to());
      if (from == index.end() || to == index.end()) continue;
      parent[find(from->second)] = find(to->second);
      edges.push_back({{"from", edge.from()}, {"to", edge.to()},
                       {"kind", edge.kind() == fleet::v1::Edge::KIND_MOTION ? "motion" : "observation"},
                       {"view", edge.has_view() ? json(edge.view()) : json(nullptr)}});
    }
    std::map<std::size_t, std::int64_t> component_ids;  // root index -> component id (its first node)
    std::map<std::int64_t, std::int64_t> component_sizes;
    json nodes = json::array();
    for (int i = 0; i < map.nodes_size(); ++i) {
      const std::size_t root = find(static_cast<std::size_t>(i));
      const auto [it, inserted] = component_ids.emplace(root, map.nodes(i).id());
      ++component_sizes[it->second];
      const auto& node = map.nodes(i);
      nodes.push_back({{"id", node.id()}, {"x", node.pose().x()}, {"y", node.pose().y()},
                       {"theta", node.pose().theta()}, {"time", node.time()}, {"component", it->second}});
    }
    std::unordered_map<std::int64_t, std::int64_t> view_node;
    json views = json::array();
    for (const auto& view : map.views()) {
      view_node[view.id()] = view.node();
      views.push_back({{"id", view.id()}, {"node", view.node()}, {"ambiguous", view.ambiguous()}});
    }
    // How each hypothesis ended, then one edge per observation that fed it.
    std::unordered_map<std::int64_t, std::string> outcome;
    std::unordered_map<std::int64_t, bool> was_conditional;
    for (const auto& decision : report->decisions()) {
      if (decision.hypothesis_kind().empty() || decision.hypothesis() < 0) continue;
      const std::string& kind = decision.kind();
      if (kind == "conditionally_accepted") was_conditional[decision.hypothesis()] = true;
      if (kind == "accepted" || kind == "rejected" || kind == "expired" || kind == "conditionally_accepted") {
        outcome[decision.hypothesis()] = kind;
      }
    }
    json hypothesis_edges = json::array();
    for (const auto& decision : report->decisions()) {
      if (decision.hypothesis_kind().empty() || decision.hypothesis() < 0) continue;
      if (decision.kind() != "hypothesis_created" && decision.kind() != "hypothesis_updated") continue;
      const auto target = view_node.find(decision.view());
      if (!index.contains(decision.node()) || target == view_node.end() || !index.contains(target->second)) continue;
      const auto ended = outcome.find(decision.hypothesis());
      const std::string status = ended == outcome.end() ? "open" : ended->second;
      hypothesis_edges.push_back({{"from", decision.node()}, {"to", target->second}, {"view", decision.view()},
                                  {"hypothesis", decision.hypothesis()}, {"kind", decision.hypothesis_kind()},
                                  {"status", status},
                                  {"conditional_merge", was_conditional.contains(decision.hypothesis())},
                                  {"time", decision.time()}});
    }
    json components = json::array();
    for (const auto& [id, size] : component_sizes) components.push_back({{"id", id}, {"nodes", size}});
    return Json(json{{"run_id", run_id}, {"robot_id", run.robot_id}, {"parameter_set", SetOf(params)},
                     {"nodes", nodes}, {"edges", edges},
                     {"views", views}, {"components", components}, {"hypothesis_edges", hypothesis_edges}});
  }

  HttpResponse MapImage(const storage::RunKey& run_id, const std::string& file,
                        const std::map<std::string, std::string>& params) {
    if (file != "parent.png" && file != "child.png" && file != "difference.png" && file != "info.json") {
      return Error(404, "map images: parent.png, child.png, difference.png (or info.json)");
    }
    auto maps = CachedMaps(run_id, SetOf(params));
    if (!maps.ok()) return Error(maps.status());
    const dashboard::RunMaps& images = **maps;
    if (file == "info.json") {
      return Json(json{{"width", images.width}, {"height", images.height}, {"resolution", images.resolution}});
    }
    HttpResponse response;
    response.content_type = "image/png";
    response.body = file == "parent.png" ? images.parent_png : file == "child.png" ? images.child_png
                                                                                   : images.difference_png;
    response.headers.emplace_back("Cache-Control", "no-cache");
    return response;
  }

  /// Rendering costs tens of milliseconds; a run page asks for three images at once, so keep the last few.
  storage::Result<std::shared_ptr<const dashboard::RunMaps>> CachedMaps(const storage::RunKey& run,
                                                                        const std::string& set) {
    return map_cache_.Get(run.robot_id + '\n' + run.run_id + '\n' + set,
                          [&] { return dashboard::RenderRunMaps(repository_, run, set); });
  }

  HttpResponse Labels(const std::map<std::string, std::string>& params) {
    std::string error;
    const auto limit = IntParam(params, "limit", 1, 1000, &error);
    if (!error.empty()) return Error(400, error);
    auto regions = repository_.ListLabelledRegions(Param(params, "parameter_set"), static_cast<int>(limit.value_or(200)));
    if (!regions.ok()) return Error(regions.status());
    json rows = json::array();
    for (const auto& region : *regions) rows.push_back(RegionJson(region));
    return Json(json{{"regions", rows}});
  }

  HttpResponse Compare(const std::map<std::string, std::string>& params) {
    std::string error;
    auto filter = FilterOf(params, &error);
    const auto limit = IntParam(params, "limit", 1, 100, &error);
    if (!filter || !error.empty()) return Error(400, error);
    const std::string a = Param(params, "a"), b = Param(params, "b");
    if (a.empty() || b.empty()) return Error(400, "a, b: two parameter set names required");
    json out{{"a", a}, {"b", b}};
    for (const auto& [name, set] : {std::pair{"stats_a", a}, std::pair{"stats_b", b}}) {
      storage::RunFilter one = *filter;
      one.parameter_set = set;
      auto statistics = repository_.Aggregate(one);
      if (!statistics.ok()) return Error(statistics.status());
      out[name] = StatisticsJson(*statistics);
    }
    json by_firmware = json::object();
    for (const auto& [name, set] : {std::pair{"a", a}, std::pair{"b", b}}) {
      storage::RunFilter one = *filter;
      one.parameter_set = set;
      auto groups = repository_.AggregateBy(one, storage::GroupBy::kFirmware);
      if (!groups.ok()) return Error(groups.status());
      for (const auto& group : *groups) by_firmware[group.key][name] = StatisticsJson(group.statistics);
    }
    out["by_firmware"] = by_firmware;
    // Runs that changed most: runs with a report under b (keyset pages), compared with their report under a.
    struct Changed {
      double score;
      json row;
    };
    std::vector<Changed> changed;
    storage::RunFilter with_b = *filter;
    with_b.parameter_set = b;
    std::optional<storage::RunCursor> after;
    int scanned = 0;
    bool truncated = false;
    while (true) {
      auto page = repository_.ListRuns(with_b, 500, after);
      if (!page.ok()) return Error(page.status());
      for (const auto& run : page->runs) {
        if (scanned >= kCompareScanLimit) {
          truncated = true;
          break;
        }
        ++scanned;
        auto report_a = repository_.GetReport(run.key(), a);
        auto report_b = repository_.GetReport(run.key(), b);
        if (!report_a.ok() || !report_b.ok()) continue;
        const json ca = ReportCountersJson(*report_a), cb = ReportCountersJson(*report_b);
        json delta = json::object();
        double score = 0.0;
        for (const char* key : {"recovery_created", "recovery_accepted", "merge_created",
                                "merge_conditionally_accepted", "merge_conditional_then_rejected", "views_ambiguous",
                                "protrusions_found", "recovery_retracted"}) {
          const std::int64_t difference = cb[key].get<std::int64_t>() - ca[key].get<std::int64_t>();
          delta[key] = difference;
          score += std::abs(static_cast<double>(difference));
        }
        const int localized = (cb["started_localized"].get<bool>() ? 1 : 0) - (ca["started_localized"].get<bool>() ? 1 : 0);
        delta["started_localized"] = localized;
        score += 5.0 * std::abs(localized);
        changed.push_back({score, json{{"run_id", run.run_id}, {"robot_id", run.robot_id}, {"firmware", run.firmware},
                                       {"started_at_ms", run.started_at_ms}, {"score", score}, {"a", ca}, {"b", cb},
                                       {"delta", delta}}});
      }
      if (truncated || !page->next) break;
      after = page->next;
    }
    std::stable_sort(changed.begin(), changed.end(), [](const Changed& x, const Changed& y) { return x.score > y.score; });
    json rows = json::array();
    std::int64_t runs_changed = 0;
    for (const auto& entry : changed) runs_changed += entry.score > 0 ? 1 : 0;
    for (std::size_t i = 0; i < changed.size() && i < static_cast<std::size_t>(limit.value_or(20)); ++i) {
      rows.push_back(changed[i].row);
    }
    out["changed_most"] = rows;
    out["runs_compared"] = changed.size();
    out["runs_changed"] = runs_changed;
    out["runs_scanned"] = scanned;
    out["scan_truncated"] = truncated;
    return Json(out);
  }

  HttpResponse Jobs(const std::map<std::string, std::string>& params) {
    std::string error;
    const auto limit = IntParam(params, "limit", 1, 500, &error);
    if (!error.empty()) return Error(400, error);
    const std::string kind = Param(params, "kind").empty() ? std::string(kReprocessJob) : Param(params, "kind");
    // Storage lists by id ascending; newest first is what people want, so keep the tail.
    auto jobs = repository_.ListJobs(std::nullopt, 1000000);
    if (!jobs.ok()) return Error(jobs.status());
    json rows = json::array();
    std::map<std::string, std::int64_t> analyses;  // per-run analysis jobs by state
    for (auto it = jobs->rbegin(); it != jobs->rend(); ++it) {
      if (it->kind == kAnalyzeRunJob && !it->parent_job_id) ++analyses[storage::JobStateName(it->state)];
      if (kind != "all" && it->kind != kind) continue;
      if (static_cast<std::int64_t>(rows.size()) < limit.value_or(50)) rows.push_back(JobJson(*it));
    }
    return Json(json{{"jobs", rows}, {"upload_analyses", analyses}});
  }

  storage::Repository& repository_;
  Authenticator& authenticator_;
  const std::string default_set_;
  const std::filesystem::path web_dir_;
  RateLimiter label_limiter_;
  RenderCache<dashboard::RunMaps> map_cache_{64u << 20, [](const dashboard::RunMaps& maps) {
                                                 return sizeof maps + maps.parent_png.size() + maps.child_png.size() +
                                                        maps.difference_png.size();
                                               }};
};

}  // namespace

void RegisterDashboardRoutes(HttpRouter& router, storage::Repository& repository, Authenticator& authenticator,
                             const FleetdConfig& config) {
  auto dashboard = std::make_shared<Dashboard>(repository, authenticator, config);
  router.AddRoute("GET", "/", [dashboard](const HttpRequest& request) { return dashboard->Static(request); });
  router.AddRoute("GET", "/api/", [dashboard](const HttpRequest& request) { return dashboard->Api(request); });
  router.AddRoute("POST", "/api/runs/", [dashboard](const HttpRequest& request) { return dashboard->Label(request); });
}

}  // namespace server
