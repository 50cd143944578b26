#include "server/dashboard_routes.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <unordered_map>

#include "dashboard_json.h"
#include "dashboard_maps.h"
#include "dashboard_static.h"
#include "http_helpers.h"
#include "render_cache.h"
#include "server/fleet_queries.h"
#include "fleet/v1/report.pb.h"
#include "server/jobs.h"
#include "server/log.h"

namespace server {
namespace {

using json = nlohmann::json;
using dashboard_json::FiguresJson;
using dashboard_json::GroupsJson;
using dashboard_json::JobJson;
using dashboard_json::Optional;
using dashboard_json::RegionJson;
using dashboard_json::ReportCountersJson;
using dashboard_json::RunJson;
using http::Error;
using http::IntParam;
using http::Json;
using http::Param;
using http::ParseInt;
using http::ParseQuery;
using http::SplitPath;

constexpr int kMaxPageSize = 200;

// ---- The routes ------------------------------------------------------------------------------------------

class Dashboard {
 public:
  Dashboard(storage::Repository& repository, Authenticator& authenticator, const FleetdConfig& config)
      : repository_(repository),
        authenticator_(authenticator),
        default_set_(config.default_parameter_set),
        label_limiter_(config.rate_limit_per_second, config.rate_limit_burst) {}

  /// GET /api/...: the first template that fits the path.
  HttpResponse Api(const HttpRequest& request) {
    const auto query = ParseQuery(request.query);
    for (const ReadRoute& route : read_routes_) {
      if (auto path = http::MatchPath(route.pattern, request.path)) {
        if (auto malformed = http::RefuseMalformedIds(*path)) return std::move(*malformed);
        return (this->*route.handler)(request, *path, query);
      }
    }
    return Error(404, "no such endpoint: " + request.path);
  }

  /// POST /api/runs/<id>/regions/<region>/label
  HttpResponse Label(const HttpRequest& request) {
    const auto path = http::MatchPath("/api/runs/{run}/regions/{region}/label", request.path);
    if (!path) return Error(404, "no such endpoint: POST " + request.path);
    if (auto malformed = http::RefuseMalformedIds(*path)) return std::move(*malformed);
    const std::string& run_id = path->at("run");
    const std::string& region_text = path->at("region");
    HttpResponse refusal;
    const std::optional<Principal> principal =
        http::AuthorizeRequest(authenticator_, request, Permission::kLabel, "labelling", &refusal);
    if (!principal) return refusal;
    if (!label_limiter_.Allow(principal->name)) return Error(429, "rate limit exceeded; retry later");
    const auto region_id = ParseInt(region_text);
    if (!region_id || *region_id < 0)
      return Error(400, "region: expected a non-negative integer, got \"" + region_text + "\"");
    const json body = json::parse(request.body, nullptr, /*allow_exceptions=*/false);
    if (body.is_discarded() || !body.is_object()) return Error(400, "body: expected a JSON object");
    const std::string label = body.value("label", "");
    if (label != "protrusion" && label != "new_space") {
      return Error(400, "label: expected \"protrusion\" or \"new_space\", got \"" + label + "\"");
    }
    std::string set = body.value("parameter_set", "");
    if (set.empty()) set = default_set_;
    auto run = queries_.Run(*principal, Param(ParseQuery(request.query), "robot"), run_id);
    if (!run.ok()) return Error(run.status());
    storage::Status labelled =
        repository_.LabelProtrusionRegion(*run, set, *region_id, label, principal->name);
    if (!labelled.ok()) {
      if (labelled.code() == storage::StatusCode::kNotFound) {
        return Error(404, "run \"" + run_id + "\" has no region " + region_text + " with parameter set \"" +
                              set + "\"");
      }
      return Error(labelled);
    }
    log::Info("region_labelled", {{"run_id", run_id},
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
  using Query = std::map<std::string, std::string>;
  using Handler = HttpResponse (Dashboard::*)(const HttpRequest&, const http::PathParams&, const Query&);
  struct ReadRoute {
    const char* pattern;
    Handler handler;
  };
  // The GET /api routes of this file, one per resource (the /api/robots routes: dashboard_map_routes.cc).
  const std::vector<ReadRoute> read_routes_ = {
      {"/api/meta", &Dashboard::Meta},
      {"/api/stats", &Dashboard::Stats},
      {"/api/runs", &Dashboard::Runs},
      {"/api/runs/{run}", &Dashboard::Run},
      {"/api/runs/{run}/graph", &Dashboard::Graph},
      {"/api/runs/{run}/map/{file}", &Dashboard::MapImage},
      {"/api/labels", &Dashboard::Labels},
      {"/api/compare", &Dashboard::Compare},
      {"/api/jobs", &Dashboard::Jobs},
  };

  /// The caller (the access guard let the request through, so its token is valid).
  storage::Result<Principal> CallerOf(const HttpRequest& request) {
    const auto header = request.headers.find("authorization");
    const Authenticator::Verdict verdict =
        authenticator_.Authenticate(header == request.headers.end() ? "" : header->second, request.peer);
    if (verdict.outcome != Authenticator::Outcome::kOk) return storage::Unavailable(verdict.message);
    return verdict.principal;
  }

  /// The run a /api/runs/{run} route names (?robot= picks among robots that share a run id; a robot reads its own).
  storage::Result<storage::RunKey> RunOf(const HttpRequest& request, const http::PathParams& path,
                                         const Query& query) {
    ASSIGN_OR_RETURN(auto caller, CallerOf(request));
    return queries_.Run(caller, Param(query, "robot"), path.at("run"));
  }

  std::string SetOf(const std::map<std::string, std::string>& params) const {
    const std::string set = Param(params, "parameter_set");
    return set.empty() ? default_set_ : set;
  }

  /// The filter from ?firmware=&robot=&model=&parameter_set=&from_ms=&to_ms=.
  std::optional<storage::RunFilter> FilterOf(const std::map<std::string, std::string>& params,
                                             std::string* error) {
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

  HttpResponse Meta(const HttpRequest&, const http::PathParams&, const Query&) {
    auto sets = repository_.ListParameterSetNames();
    if (!sets.ok()) return Error(sets.status());
    auto firmware = repository_.AggregateBy(storage::RunFilter{}, storage::GroupBy::kFirmware);
    if (!firmware.ok()) return Error(firmware.status());
    json firmware_keys = json::array();
    for (const auto& group : *firmware) firmware_keys.push_back(group.key);
    return Json(json{
        {"parameter_sets", *sets}, {"firmware", firmware_keys}, {"default_parameter_set", default_set_}});
  }

  HttpResponse Stats(const HttpRequest& request, const http::PathParams&, const Query& params) {
    std::string error;
    auto filter = FilterOf(params, &error);
    if (!filter) return Error(400, error);
    if (filter->parameter_set.empty()) filter->parameter_set = default_set_;  // a run counts once
    auto caller = CallerOf(request);
    if (!caller.ok()) return Error(caller.status());
    auto by_day = queries_.Statistics(*caller, *filter, storage::GroupBy::kDay);
    if (!by_day.ok()) return Error(by_day.status());
    auto by_firmware = queries_.Statistics(*caller, *filter, storage::GroupBy::kFirmware);
    if (!by_firmware.ok()) return Error(by_firmware.status());
    auto maps = queries_.Maps(*caller, *filter);
    if (!maps.ok()) return Error(maps.status());
    auto confusion = queries_.Confusion(*caller, filter->parameter_set);
    if (!confusion.ok()) return Error(confusion.status());
    const ConfusionMatrix& m = *confusion;
    return Json(json{{"parameter_set", filter->parameter_set},
                     {"total", FiguresJson(by_day->total)},
                     {"by_day", GroupsJson(by_day->groups)},
                     {"by_firmware", GroupsJson(by_firmware->groups)},
                     {"maps",
                      {{"maps", maps->maps},
                       {"maps_with_ambiguous_views", maps->maps_with_ambiguous_views},
                       {"share_with_ambiguous_views", Optional(maps->share_with_ambiguous_views)},
                       {"ambiguous_share_histogram", maps->ambiguous_share_histogram}}},
                     {"confusion",
                      {{"true_positive", m.true_positive},
                       {"false_positive", m.false_positive},
                       {"false_negative", m.false_negative},
                       {"true_negative", m.true_negative},
                       {"unclassified", m.unclassified},
                       {"labelled", m.labelled},
                       {"recall", Optional(m.recall)},
                       {"precision", Optional(m.precision)},
                       {"false_positive_rate", Optional(m.false_positive_rate)}}}});
  }

  HttpResponse Runs(const HttpRequest& request, const http::PathParams&, const Query& params) {
    std::string error;
    auto filter = FilterOf(params, &error);
    const auto limit = IntParam(params, "limit", 1, kMaxPageSize, &error);
    const auto after_ms = IntParam(params, "after_ms", 0, 1LL << 53, &error);
    if (!filter || !error.empty()) return Error(400, error);
    auto caller = CallerOf(request);
    if (!caller.ok()) return Error(caller.status());
    RunsQuery query;
    query.filter = *filter;
    query.page_size = static_cast<int>(limit.value_or(50));
    if (after_ms)
      query.after = storage::RunCursor{*after_ms, Param(params, "after_id"), Param(params, "after_robot")};
    query.report_set = SetOf(params);
    query.with_regions = true;
    query.only_with_regions = Param(params, "with_regions") == "1";
    auto page = queries_.Runs(*caller, query);
    if (!page.ok()) return Error(page.status());
    json runs = json::array();
    for (const RunRow& row : page->rows) {
      json out = RunJson(row.run);
      out["report"] = row.report ? ReportCountersJson(*row.report) : json(nullptr);
      out["regions"] = row.regions;
      out["regions_labelled"] = row.regions_labelled;
      runs.push_back(std::move(out));
    }
    json out{{"parameter_set", query.report_set}, {"runs", runs}, {"next", nullptr}};
    if (page->next) {
      out["next"] = json{{"after_ms", page->next->started_at_ms},
                         {"after_id", page->next->run_id},
                         {"after_robot", page->next->robot_id}};
    }
    return Json(out);
  }

  HttpResponse Run(const HttpRequest& request, const http::PathParams& path, const Query& params) {
    auto resolved = RunOf(request, path, params);
    if (!resolved.ok()) return Error(resolved.status());
    const storage::RunKey& key = *resolved;
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
      out["analysis"] =
          json{{"map_version", report.map_version()},
               {"seconds_to_conditional_relocalization", report.seconds_to_conditional_relocalization()},
               {"seconds_to_full_relocalization", report.seconds_to_full_relocalization()},
               {"replay_seconds", report.replay_seconds()},
               {"detection_seconds", report.detection_seconds()},
               {"feature_names",
                std::vector<std::string>(report.feature_names().begin(), report.feature_names().end())},
               {"divergence",
                {{"robot_nodes", d.robot_nodes()},
                 {"rerun_nodes", d.rerun_nodes()},
                 {"robot_observation_edges", d.robot_observation_edges()},
                 {"rerun_observation_edges", d.rerun_observation_edges()},
                 {"node_position_rms", d.node_position_rms()}}},
               {"counts",
                {{"direct_edges", report.counts().direct_edges()},
                 {"recovery_expired", report.counts().recovery_expired()},
                 {"recovery_rejected", report.counts().recovery_rejected()},
                 {"merge_accepted", report.counts().merge_accepted()},
                 {"merge_expired", report.counts().merge_expired()},
                 {"merge_rejected", report.counts().merge_rejected()},
                 {"components_created", report.counts().components_created()}}}};
      if (report.has_ground_truth()) {
        const auto& g = report.ground_truth();
        out["analysis"]["ground_truth"] = {
            {"trajectory_rmse", g.trajectory_rmse()},
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
      timeline.push_back({{"sequence", decision.sequence},
                          {"time_s", decision.time_s},
                          {"kind", decision.kind},
                          {"outcome", decision.outcome},
                          {"subject_id", decision.subject_id},
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
  HttpResponse Graph(const HttpRequest& request, const http::PathParams& path, const Query& params) {
    auto resolved = RunOf(request, path, params);
    if (!resolved.ok()) return Error(resolved.status());
    const storage::RunKey& run = *resolved;
    const std::string& run_id = run.run_id;
    auto report = queries_.Report(run, SetOf(params));
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
      edges.push_back({{"from", edge.from()},
                       {"to", edge.to()},
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
      nodes.push_back({{"id", node.id()},
                       {"x", node.pose().x()},
                       {"y", node.pose().y()},
                       {"theta", node.pose().theta()},
                       {"time", node.time()},
                       {"component", it->second}});
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
      if (!index.contains(decision.node()) || target == view_node.end() || !index.contains(target->second))
        continue;
      const auto ended = outcome.find(decision.hypothesis());
      const std::string status = ended == outcome.end() ? "open" : ended->second;
      hypothesis_edges.push_back({{"from", decision.node()},
                                  {"to", target->second},
                                  {"view", decision.view()},
                                  {"hypothesis", decision.hypothesis()},
                                  {"kind", decision.hypothesis_kind()},
                                  {"status", status},
                                  {"conditional_merge", was_conditional.contains(decision.hypothesis())},
                                  {"time", decision.time()}});
    }
    json components = json::array();
    for (const auto& [id, size] : component_sizes) components.push_back({{"id", id}, {"nodes", size}});
    return Json(json{{"run_id", run_id},
                     {"robot_id", run.robot_id},
                     {"parameter_set", SetOf(params)},
                     {"nodes", nodes},
                     {"edges", edges},
                     {"views", views},
                     {"components", components},
                     {"hypothesis_edges", hypothesis_edges}});
  }

  HttpResponse MapImage(const HttpRequest& request, const http::PathParams& path, const Query& params) {
    const std::string& file = path.at("file");
    if (file != "parent.png" && file != "child.png" && file != "difference.png" && file != "info.json") {
      return Error(404, "map images: parent.png, child.png, difference.png (or info.json)");
    }
    auto run = RunOf(request, path, params);
    if (!run.ok()) return Error(run.status());
    auto maps = CachedMaps(*run, SetOf(params));
    if (!maps.ok()) return Error(maps.status());
    const dashboard::RunMaps& images = **maps;
    if (file == "info.json") {
      return Json(
          json{{"width", images.width}, {"height", images.height}, {"resolution", images.resolution}});
    }
    HttpResponse response;
    response.content_type = "image/png";
    response.body = file == "parent.png"  ? images.parent_png
                    : file == "child.png" ? images.child_png
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

  HttpResponse Labels(const HttpRequest& request, const http::PathParams&, const Query& params) {
    std::string error;
    const auto limit = IntParam(params, "limit", 1, 1000, &error);
    if (!error.empty()) return Error(400, error);
    auto caller = CallerOf(request);
    if (!caller.ok()) return Error(caller.status());
    auto regions =
        queries_.Labels(*caller, Param(params, "parameter_set"), static_cast<int>(limit.value_or(200)));
    if (!regions.ok()) return Error(regions.status());
    json rows = json::array();
    for (const auto& region : *regions) rows.push_back(RegionJson(region));
    return Json(json{{"regions", rows}});
  }

  HttpResponse Compare(const HttpRequest& request, const http::PathParams&, const Query& params) {
    std::string error;
    auto filter = FilterOf(params, &error);
    const auto limit = IntParam(params, "limit", 1, 100, &error);
    if (!filter || !error.empty()) return Error(400, error);
    const std::string a = Param(params, "a"), b = Param(params, "b");
    if (a.empty() || b.empty()) return Error(400, "a, b: two parameter set names required");
    auto caller = CallerOf(request);
    if (!caller.ok()) return Error(caller.status());
    auto comparison = queries_.Compare(*caller, *filter, a, b, static_cast<std::size_t>(limit.value_or(20)));
    if (!comparison.ok()) return Error(comparison.status());
    json by_firmware = json::object();
    for (const auto& [firmware, sides] : comparison->by_firmware) {
      if (sides.first) by_firmware[firmware]["a"] = FiguresJson(*sides.first);
      if (sides.second) by_firmware[firmware]["b"] = FiguresJson(*sides.second);
    }
    json rows = json::array();
    for (const RunChange& change : comparison->most_changed) {
      const json ca = ReportCountersJson(change.a), cb = ReportCountersJson(change.b);
      json delta = json::object();
      for (const char* key : {"recovery_created", "recovery_accepted", "merge_created",
                              "merge_conditionally_accepted", "merge_conditional_then_rejected",
                              "views_ambiguous", "protrusions_found", "recovery_retracted"}) {
        delta[key] = cb[key].get<std::int64_t>() - ca[key].get<std::int64_t>();
      }
      delta["started_localized"] =
          (change.b.started_localized ? 1 : 0) - (change.a.started_localized ? 1 : 0);
      rows.push_back(json{{"run_id", change.run.run_id},
                          {"robot_id", change.run.robot_id},
                          {"firmware", change.run.firmware},
                          {"started_at_ms", change.run.started_at_ms},
                          {"score", change.change},
                          {"a", ca},
                          {"b", cb},
                          {"delta", delta}});
    }
    return Json(json{{"a", a},
                     {"b", b},
                     {"stats_a", FiguresJson(comparison->a)},
                     {"stats_b", FiguresJson(comparison->b)},
                     {"by_firmware", by_firmware},
                     {"changed_most", rows},
                     {"runs_compared", comparison->runs_compared},
                     {"runs_changed", comparison->runs_changed},
                     {"runs_scanned", comparison->runs_compared},
                     {"scan_truncated", comparison->scan_truncated}});
  }

  HttpResponse Jobs(const HttpRequest& request, const http::PathParams&, const Query& params) {
    std::string error;
    const auto limit = IntParam(params, "limit", 1, 500, &error);
    if (!error.empty()) return Error(400, error);
    const std::string kind =
        Param(params, "kind").empty() ? std::string(kReprocessJob) : Param(params, "kind");
    auto caller = CallerOf(request);
    if (!caller.ok()) return Error(caller.status());
    auto jobs = queries_.Jobs(*caller, kind, static_cast<int>(limit.value_or(50)));
    if (!jobs.ok()) return Error(jobs.status());
    json rows = json::array();
    for (const auto& job : jobs->jobs) rows.push_back(JobJson(job));
    json analyses = json::object();
    for (const auto& [state, count] : jobs->analyses) analyses[state] = count;
    return Json(json{{"jobs", rows}, {"upload_analyses", analyses}});
  }

  storage::Repository& repository_;
  Authenticator& authenticator_;
  const std::string default_set_;
  FleetQueries queries_{repository_, default_set_};
  RateLimiter label_limiter_;
  RenderCache<dashboard::RunMaps> map_cache_{64u << 20, [](const dashboard::RunMaps& maps) {
                                               return sizeof maps + maps.parent_png.size() +
                                                      maps.child_png.size() + maps.difference_png.size();
                                             }};
};

}  // namespace

void RegisterDashboardRoutes(HttpRouter& router, storage::Repository& repository,
                             Authenticator& authenticator, const FleetdConfig& config) {
  auto dashboard = std::make_shared<Dashboard>(repository, authenticator, config);
  RegisterStaticRoutes(router);
  router.AddRoute("GET", "/api/",
                  [dashboard](const HttpRequest& request) { return dashboard->Api(request); });
  router.AddRoute("POST", "/api/runs/",
                  [dashboard](const HttpRequest& request) { return dashboard->Label(request); });
}

}  // namespace server
