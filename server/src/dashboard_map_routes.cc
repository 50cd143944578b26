// The dashboard's map review endpoints (see dashboard_routes.h for the list). Reads are open to whoever
// reaches the HTTP port, like the rest of the dashboard; repairs and reviews need an engineer's token.
#include <atomic>
#include <memory>
#include <nlohmann/json.hpp>

#include "analyzer/map_comparison.h"
#include "analyzer/map_metadata.h"
#include "analyzer/map_repair.h"
#include "analyzer/telemetry_codec.h"
#include "http_helpers.h"
#include "multipart_form.h"
#include "render_cache.h"
#include "server/analysis.h"
#include "server/dashboard_routes.h"
#include "server/map_history.h"
#include "slamcore/optimizer.h"

namespace server {
namespace {

using json = nlohmann::json;
using http::Error;
using http::Json;

/// The JSON spelling of a wire state: storage's lower-case name ("upload", "pending", "open", …; "" for none).
template <typename ProtoEnum>
std::string Spelled(ProtoEnum value) {
  return std::string(NameOf(value));
}

json VersionJson(const fleet::v1::MapVersion& version) {
  return {{"robot_id", version.robot_id()},
          {"version", version.version()},
          {"parent_version", version.parent_version()},
          {"snapshot_id", version.snapshot_id()},
          {"origin", Spelled(version.version_origin())},
          {"run_id", version.run_id()},
          {"action", Spelled(version.version_action())},
          {"action_detail", version.action_detail()},
          {"created_by", version.created_by()},
          {"reason", version.reason()},
          {"created_at", version.created_at()},
          {"approval", Spelled(version.approval_state())},
          {"approved_by", version.approved_by()},
          {"approved_at", version.approved_at()},
          {"nodes", version.nodes()},
          {"edges", version.edges()},
          {"observation_edges", version.observation_edges()},
          {"views", version.views()},
          {"components", version.components()},
          {"known_area_m2", version.known_area_m2()},
          {"chi2", version.chi2()},
          {"open_findings", version.open_findings()},
          {"current", version.current()}};
}

json FindingJson(const fleet::v1::MapFinding& finding) {
  json evidence = json::parse(finding.evidence_json(), nullptr, /*allow_exceptions=*/false);
  if (evidence.is_discarded()) evidence = json::object();
  json out = {{"finding_id", finding.finding_id()},
              {"kind", Spelled(finding.finding_kind())},
              {"severity", finding.severity()},
              {"summary", finding.summary()},
              {"state", Spelled(finding.finding_state())},
              {"evidence", evidence},
              {"edge_from", finding.edge_from()},
              {"edge_to", finding.edge_to()}};
  if (finding.has_hypothesis()) out["hypothesis"] = finding.hypothesis();
  if (finding.world_bbox_size() == 4) {
    out["world_bbox"] = {finding.world_bbox(0), finding.world_bbox(1), finding.world_bbox(2),
                         finding.world_bbox(3)};
  }
  return out;
}

/// What the version page draws over the picture: rooms with their names at their centres (the pixels stay on
/// the server: the picture shows them), and the shapes and points in world metres.
json MetadataJson(const fleet::v1::MapMetadata& metadata) {
  const auto shapes = [](const google::protobuf::RepeatedPtrField<fleet::v1::MapShape>& list) {
    json out = json::array();
    for (const fleet::v1::MapShape& shape : list)
      out.push_back(
          {{"type", shape.type()}, {"xy", std::vector<double>(shape.xy().begin(), shape.xy().end())}});
    return out;
  };
  json rooms = json::array(), points = json::array();
  for (const fleet::v1::MapRoom& room : metadata.rooms()) {
    json row = {{"segment_id", room.segment_id()},
                {"name", room.name()},
                {"pixel_count", room.pixel_count()},
                {"area_m2", room.area_m2()}};
    if (const auto centre = analyzer::RoomCentre(room, metadata.resolution()))
      row["centre"] = {(*centre)[0], (*centre)[1]};
    rooms.push_back(row);
  }
  for (const fleet::v1::MapPoint& point : metadata.points()) {
    json row = {{"type", point.type()}, {"x", point.x()}, {"y", point.y()}};
    if (point.has_theta()) row["theta"] = point.theta();
    points.push_back(row);
  }
  return {{"format", metadata.format()},       {"rooms", rooms},
          {"paths", shapes(metadata.paths())}, {"virtual_walls", shapes(metadata.virtual_walls())},
          {"zones", shapes(metadata.zones())}, {"points", points}};
}

class MapRoutes {
 public:
  MapRoutes(storage::Repository& repository, Authenticator& authenticator, const FleetdConfig& config)
      : repository_(repository),
        authenticator_(authenticator),
        history_(repository, MapPolicyOf(config)),
        limiter_(config.rate_limit_per_second, config.rate_limit_burst) {}

  HttpResponse Get(const HttpRequest& request) {
    if (http::MatchPath("/api/robots", request.path)) return Robots(http::ParseQuery(request.query));
    if (auto path = http::MatchPath("/api/robots/{robot}", request.path)) {
      if (auto malformed = http::RefuseMalformedIds(*path)) return std::move(*malformed);
      return Robot(path->at("robot"));
    }
    if (auto path = http::MatchPath("/api/robots/{robot}/maps", request.path)) {
      if (auto malformed = http::RefuseMalformedIds(*path)) return std::move(*malformed);
      return Versions(path->at("robot"));
    }
    // The routes of one version: {version} is a number or "current".
    using VersionRoute = HttpResponse (MapRoutes::*)(const std::string& robot, std::int64_t version,
                                                     const http::PathParams& path);
    static constexpr std::pair<const char*, VersionRoute> kVersionRoutes[] = {
        {"/api/robots/{robot}/maps/{version}", &MapRoutes::Version},
        {"/api/robots/{robot}/maps/{version}/graph", &MapRoutes::Graph},
        {"/api/robots/{robot}/maps/{version}/map.png", &MapRoutes::Picture},
        {"/api/robots/{robot}/maps/{version}/export/{file}", &MapRoutes::Export},
    };
    for (const auto& [pattern, route] : kVersionRoutes) {
      const auto path = http::MatchPath(pattern, request.path);
      if (!path) continue;
      if (auto malformed = http::RefuseMalformedIds(*path)) return std::move(*malformed);
      const std::string& text = path->at("version");
      const auto version = VersionOf(text);
      if (!version)
        return Error(400, "version: expected a positive integer or \"current\", got \"" + text + "\"");
      return (this->*route)(path->at("robot"), *version, *path);
    }
    return Error(404, "no such endpoint: " + request.path);
  }

  HttpResponse Post(const HttpRequest& request) {
    const auto import_path = http::MatchPath("/api/robots/{robot}/maps/import", request.path);
    const auto repair_path = http::MatchPath("/api/robots/{robot}/maps/{version}/repair", request.path);
    const auto review_path = http::MatchPath("/api/robots/{robot}/maps/{version}/review", request.path);
    const auto& path = import_path ? import_path : repair_path ? repair_path : review_path;
    if (!path) return Error(404, "no such endpoint: POST " + request.path);
    if (auto malformed = http::RefuseMalformedIds(*path)) return std::move(*malformed);
    const std::string& robot = path->at("robot");
    HttpResponse refusal;
    const auto principal =
        http::AuthorizeRequest(authenticator_, request, Permission::kRepairMap, "repairing maps", &refusal);
    if (!principal) return refusal;
    if (!limiter_.Allow(principal->name)) return Error(429, "rate limit exceeded; retry later");
    if (import_path) return Import(robot, request, principal->name);
    const std::string& version_text = path->at("version");
    const auto version = http::ParseInt(version_text);
    if (!version || *version <= 0)
      return Error(400, "version: expected a positive integer, got \"" + version_text + "\"");
    const json body = json::parse(request.body, nullptr, /*allow_exceptions=*/false);
    if (body.is_discarded() || !body.is_object()) return Error(400, "body: expected a JSON object");
    try {
      if (review_path) {
        if (!body.contains("approve") || !body["approve"].is_boolean())
          return Error(400, "approve: expected true or false");
        auto reviewed = history_.Review(robot, *version, body["approve"].get<bool>(), principal->name);
        if (!reviewed.ok()) return Error(reviewed.status());
        return Json(VersionJson(*reviewed));
      }
      RepairRequest repair;
      repair.robot_id = robot;
      repair.base_version = *version;
      auto action = RepairActionNamed(body.value("action", ""), "action");
      if (!action.ok()) return Error(action.status());
      repair.action = *action;
      // Each action's own fields, beside "action" in the body.
      std::visit(
          Overloaded{[&](RejectEdge& edge) {
                       edge.from = body.value("from", std::int64_t{0});
                       edge.to = body.value("to", std::int64_t{0});
                       if (body.contains("view") && !body["view"].is_null()) {
                         edge.view = body["view"].get<std::int64_t>();
                       }
                     },
                     [&](RejectHypothesis& rejected) {
                       rejected.hypothesis = body.value("hypothesis", std::int64_t{0});
                     },
                     [&](CutFinding& cut) { cut.finding_id = body.value("finding_id", std::int64_t{0}); },
                     [](Rollback&) {}, [](Undo&) {}},
          repair.action);
      repair.reason = body.value("reason", "");
      repair.approve = body.value("approve", false);
      repair.requested_by = principal->name;
      auto repaired = history_.Repair(repair);
      if (!repaired.ok()) return Error(repaired.status());
      json findings = json::array();
      for (const auto& finding : repaired->findings) findings.push_back(FindingJson(finding));
      return Json({{"version", VersionJson(repaired->version)}, {"findings", findings}});
    } catch (const json::exception& error) {
      return Error(400, std::string("body: a field has the wrong type (") + error.what() + ")");
    }
  }

  /// A map uploaded from the robot's map page: a ValetudoMap export (the body, as the file), or a map_server
  /// pair as multipart/form-data (parts "yaml" and "image"). Either becomes a pending version of the robot's
  /// history, compared with the previous one as `fleetctl import` does (MapHistory::Import).
  HttpResponse Import(const std::string& robot_id, const HttpRequest& request,
                      const std::string& requested_by) {
    const auto type = request.headers.find("content-type");
    const bool form = type != request.headers.end() && type->second.rfind("multipart/form-data", 0) == 0;
    std::string source = "dashboard upload";
    // A deflated body of 1 MiB can inflate to the upload limit and cost some ten times that as a JSON
    // document: decodes are counted, and one past the limit is told to come back.
    if (decoding_.fetch_add(1) >= kMaxConcurrentDecodes) {
      --decoding_;
      HttpResponse busy = Error(503, "busy decoding other map uploads; retry in a few seconds");
      busy.headers.emplace_back("Retry-After", "5");
      return busy;
    }
    auto imported =
        form ? MapServerUpload(type->second, request.body, &source) : ValetudoUpload(request.body);
    --decoding_;
    // Everything wrong with an upload is the uploader's (DATA_LOSS from a malformed PGM included): 400.
    if (!imported.ok()) return Error(400, imported.status().message());
    auto version = history_.Import(robot_id, imported->snapshot, imported->metadata, source,
                                   "uploaded on the robot's map page", /*approve=*/false, requested_by);
    if (!version.ok()) return Error(version.status());
    return Json({{"version", VersionJson(*version)}});
  }

 private:
  static constexpr int kMaxConcurrentDecodes = 2;
  /// Cells an uploaded map may decode to (a PGM is bounded by the 1 MiB body already).
  static constexpr std::int64_t kMaxUploadCells = analyzer::kMaxUploadedMapCells;

  /// An upload is held to far less than a file on the engineer's disk (analyzer::ValetudoUploadLimits).
  static slamcore::Result<analyzer::ImportedMap> ValetudoUpload(const std::string& body) {
    ASSIGN_OR_RETURN(auto map, analyzer::ParseValetudoMap(body, "uploaded ValetudoMap export",
                                                          analyzer::ValetudoUploadLimits()));
    return analyzer::ImportValetudo(map);
  }

  /// The YAML may name only the uploaded image (no path): an upload never reads a file of the server.
  static slamcore::Result<analyzer::ImportedMap> MapServerUpload(const std::string& content_type,
                                                                 const std::string& body,
                                                                 std::string* source) {
    auto parts = http::ParseMultipartForm(content_type, body, /*max_parts=*/4);
    if (!parts.ok()) return slamcore::InvalidArgument(parts.status().message());
    const http::FormPart *yaml = nullptr, *image = nullptr;
    for (const http::FormPart& part : *parts) {
      if (part.name != "yaml" && part.name != "image") {
        return slamcore::InvalidArgument("multipart: unknown part \"" + part.name +
                                         "\" (expected yaml and image)");
      }
      const http::FormPart*& slot = part.name == "yaml" ? yaml : image;
      if (slot != nullptr)
        return slamcore::InvalidArgument("multipart: part \"" + part.name + "\" given twice");
      slot = &part;
    }
    if (yaml == nullptr) return slamcore::InvalidArgument("yaml: missing (the map_server YAML file)");
    if (image == nullptr)
      return slamcore::InvalidArgument("image: missing (the PGM or PNG image the YAML names)");
    if (image->filename.empty()) return slamcore::InvalidArgument("image: the part has no filename");
    const auto read_image = [&](const std::string& name) -> slamcore::Result<std::string> {
      if (name != image->filename || name.find_first_of("/\\") != std::string::npos) {
        return slamcore::InvalidArgument("yaml: image \"" + name.substr(0, 128) +
                                         "\" names a file outside the upload (the uploaded image is \"" +
                                         image->filename + "\")");
      }
      // A PNG's header says how large it inflates: refuse one past the upload's bound before decoding it.
      if (image->body.size() >= 24 && image->body.compare(0, 4, "\x89PNG") == 0) {
        const auto be32 = [&](std::size_t at) {
          std::uint64_t value = 0;
          for (std::size_t i = 0; i < 4; ++i)
            value = value << 8 | static_cast<unsigned char>(image->body[at + i]);
          return value;
        };
        if (be32(16) * be32(20) > static_cast<std::uint64_t>(kMaxUploadCells)) {
          return slamcore::InvalidArgument(
              "image: " + std::to_string(be32(16)) + " x " + std::to_string(be32(20)) +
              " pixels, more than the upload limit of " + std::to_string(kMaxUploadCells));
        }
      }
      return image->body;
    };
    ASSIGN_OR_RETURN(auto grid, slamcore::ParseMapServerYaml(yaml->body, "yaml", read_image));
    *source = "dashboard upload: " + (yaml->filename.empty() ? std::string("yaml") : yaml->filename) + " + " +
              image->filename;
    return analyzer::ImportMapServer(grid);
  }

  /// "current" is 0 (MapHistory's "the current version").
  static std::optional<std::int64_t> VersionOf(const std::string& text) {
    if (text == "current") return 0;
    const auto value = http::ParseInt(text);
    if (!value || *value <= 0) return std::nullopt;
    return value;
  }

  static json RobotJson(const storage::RobotMapSummary& summary) {
    json row = {{"robot_id", summary.robot.robot_id},         {"robot_model", summary.robot.robot_model},
                {"firmware", summary.robot.firmware},         {"versions", summary.versions},
                {"current_version", summary.current_version}, {"head_version", summary.versions},
                {"pending", summary.pending_versions}};
    if (summary.newest_approval) {
      row["head_approval"] = std::string(storage::Name(*summary.newest_approval));
      row["open_findings"] = summary.newest_open_findings;
    }
    return row;
  }

  /// A page of robots in id order: ?limit=1..1000 (RobotSummaryQuery's default), ?after=<robot id> (the previous page's
  /// next.after), ?pending=1 for only the robots with a version waiting for review.
  HttpResponse Robots(const std::map<std::string, std::string>& params) {
    std::string error;
    const auto limit = http::IntParam(params, "limit", 1, storage::kMaxRobotPage, &error);
    const std::string pending = http::Param(params, "pending");
    if (pending != "" && pending != "0" && pending != "1")
      error = "pending: expected 0 or 1, got \"" + pending + "\"";
    if (!error.empty()) return Error(400, error);
    storage::RobotSummaryQuery query;
    query.after_robot_id = http::Param(params, "after");
    if (limit) query.limit = static_cast<int>(*limit);
    query.only_pending = pending == "1";
    auto page = repository_.ListRobotSummaries(query);
    if (!page.ok()) return Error(page.status());
    json robots = json::array();
    for (const storage::RobotMapSummary& summary : page->robots) robots.push_back(RobotJson(summary));
    json next = nullptr;
    if (page->more) next = {{"after", page->robots.back().robot.robot_id}};
    return Json({{"robots", robots}, {"total", page->total}, {"next", next}});
  }

  HttpResponse Robot(const std::string& robot) {
    auto summary = repository_.GetRobotSummary(robot);
    if (!summary.ok()) return Error(summary.status());
    return Json(RobotJson(*summary));
  }

  HttpResponse Versions(const std::string& robot) {
    std::int64_t current = 0, head = 0;
    auto versions = history_.List(robot, &current, &head);
    if (!versions.ok()) return Error(versions.status());
    if (versions->empty() && repository_.GetRobot(robot).status().code() == storage::StatusCode::kNotFound) {
      return Error(404, "no robot \"" + robot + "\"");
    }
    json out = json::array();
    for (const auto& version : *versions) out.push_back(VersionJson(version));
    return Json(
        {{"robot_id", robot}, {"current_version", current}, {"head_version", head}, {"versions", out}});
  }

  HttpResponse Version(const std::string& robot, std::int64_t version, const http::PathParams&) {
    auto detail = history_.Get(robot, version);
    if (!detail.ok()) return Error(detail.status());
    json findings = json::array();
    for (const auto& finding : detail->findings) findings.push_back(FindingJson(finding));
    json out = {{"version", VersionJson(detail->version)}, {"findings", findings}};
    if (detail->metadata) out["metadata"] = MetadataJson(*detail->metadata);
    return Json(out);
  }

  /// A version's map with what names it.
  struct VersionMap {
    slamcore::Map map;
    std::int64_t version = 0;
    std::string snapshot_id, run_id;
  };
  storage::Result<VersionMap> LoadMap(const std::string& robot, std::int64_t version) {
    fleet::v1::MapSnapshot snapshot;
    ASSIGN_OR_RETURN(auto detail, history_.Get(robot, version, &snapshot));
    ASSIGN_OR_RETURN(auto map, analyzer::FromProto(snapshot, "snapshot"));
    return VersionMap{std::move(map), detail.version.version(), detail.version.snapshot_id(),
                      detail.version.run_id()};
  }

  /// The home grid of a map, rendered once per snapshot (a version page asks for it several times: its
  /// picture and the graph's frame, its parent's for before/after).
  storage::Result<std::shared_ptr<const slamcore::OccupancyGrid>> HomeGrid(const std::string& snapshot_id,
                                                                           const slamcore::Map& map) {
    return grid_cache_.Get(snapshot_id, [&]() -> storage::Result<slamcore::OccupancyGrid> {
      ASSIGN_OR_RETURN(auto grid, analyzer::RenderHomeGrid(map));
      return grid;
    });
  }

  /// The pose graph with every edge's χ² and source, and the home grid's frame so that the page can draw
  /// the graph over map.png.
  HttpResponse Graph(const std::string& robot, std::int64_t version, const http::PathParams&) {
    auto loaded = LoadMap(robot, version);
    if (!loaded.ok()) return Error(loaded.status());
    auto run_nodes = history_.NodesAddedByRun({robot, loaded->run_id}, loaded->map);
    if (!run_nodes.ok()) return Error(run_nodes.status());
    const slamcore::PoseGraph& graph = loaded->map.graph;
    json nodes = json::array(), edges = json::array(), components = json::array();
    for (const slamcore::Node& node : graph.nodes()) {
      nodes.push_back(json::array({node.id, node.pose.x(), node.pose.y(), node.pose.theta(),
                                   graph.ComponentOf(node.id), run_nodes->contains(node.id) ? 1 : 0}));
    }
    for (const slamcore::Edge& edge : graph.edges()) {
      json row = {{"from", edge.from},
                  {"to", edge.to},
                  {"kind", edge.kind == slamcore::EdgeKind::kMotion ? "motion" : "observation"},
                  {"chi2", slamcore::EdgeChi2(graph, edge)}};
      if (edge.view) row["view"] = *edge.view;
      if (edge.hypothesis) row["hypothesis"] = *edge.hypothesis;
      edges.push_back(row);
    }
    for (const slamcore::ComponentId component : graph.Components()) {
      components.push_back({{"id", component}, {"nodes", graph.ComponentSize(component)}});
    }
    json ambiguous = json::array();
    for (const slamcore::View& view : graph.views()) {
      if (view.ambiguous) ambiguous.push_back(view.id);
    }
    auto grid = HomeGrid(loaded->snapshot_id, loaded->map);
    if (!grid.ok()) return Error(grid.status());
    return Json({{"robot_id", robot},
                 {"version", loaded->version},
                 {"nodes", nodes},
                 {"edges", edges},
                 {"components", components},
                 {"ambiguous_views", ambiguous},
                 {"grid",
                  {{"width", (*grid)->width},
                   {"height", (*grid)->height},
                   {"resolution", (*grid)->resolution},
                   {"origin_x", (*grid)->origin_x},
                   {"origin_y", (*grid)->origin_y}}}});
  }

  HttpResponse Picture(const std::string& robot, std::int64_t version, const http::PathParams&) {
    auto loaded = LoadMap(robot, version);
    if (!loaded.ok()) return Error(loaded.status());
    auto grid = HomeGrid(loaded->snapshot_id, loaded->map);
    if (!grid.ok()) return Error(grid.status());
    if ((*grid)->width == 0) {
      return Error(409, "version " + std::to_string(loaded->version) + " has no occupancy patches to draw");
    }
    auto png = slamcore::EncodePng(**grid);
    if (!png.ok()) return Error(png.status());
    HttpResponse response;
    response.content_type = "image/png";
    response.body = std::move(png).value();
    // A version never changes: its picture may be cached (unless asked for as "current").
    response.headers.emplace_back("Cache-Control", version > 0 ? "max-age=86400, immutable" : "no-cache");
    return response;
  }

  HttpResponse Export(const std::string& robot, std::int64_t version, const http::PathParams& path) {
    const std::string& file = path.at("file");
    const std::string format = file == "map.g2o"                           ? "g2o"
                               : (file == "map.pgm" || file == "map.yaml") ? "map_server"
                               : file == "map.json"                        ? "valetudo"
                                                                           : "";
    if (format.empty())
      return Error(404, "export: expected map.pgm, map.yaml, map.g2o or map.json, got \"" + file + "\"");
    auto files = history_.Export(robot, version, format);
    if (!files.ok()) return Error(files.status());
    const std::string extension = file.substr(file.rfind('.'));
    for (const fleet::v1::ExportedFile& exported : *files) {
      if (!exported.name().ends_with(extension)) continue;
      HttpResponse response;
      response.content_type = extension == ".pgm"    ? "image/x-portable-graymap"
                              : extension == ".json" ? "application/json"
                                                     : "text/plain; charset=utf-8";
      response.body = exported.content();
      response.headers.emplace_back("Content-Disposition",
                                    "attachment; filename=\"" + exported.name() + "\"");
      return response;
    }
    return Error(500, "export made no " + extension + " file");
  }

  storage::Repository& repository_;
  Authenticator& authenticator_;
  MapHistory history_;
  RateLimiter limiter_;
  std::atomic<int> decoding_{0};  // uploads being decoded now (Import)
  // Rendered grids by snapshot id.
  RenderCache<slamcore::OccupancyGrid> grid_cache_{
      256u << 20, [](const slamcore::OccupancyGrid& grid) { return sizeof grid + grid.cells.size(); }};
};

}  // namespace

void RegisterMapRoutes(HttpRouter& router, storage::Repository& repository, Authenticator& authenticator,
                       const FleetdConfig& config) {
  auto routes = std::make_shared<MapRoutes>(repository, authenticator, config);
  router.AddRoute("GET", "/api/robots",
                  [routes](const HttpRequest& request) { return routes->Get(request); });
  router.AddRoute("POST", "/api/robots/",
                  [routes](const HttpRequest& request) { return routes->Post(request); });
}

}  // namespace server
