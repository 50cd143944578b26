#include "map_commands.h"

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "fleet_client/map_stream.h"

namespace fleetctl {
namespace {

void PrintVersionHeader() {
  std::printf("%-4s %-4s %-7s %-9s %-18s %-9s %7s %7s %5s %9s %9s %5s  %s\n", "", "ver", "parent", "origin",
              "action", "approval", "nodes", "edges", "comp", "area m2", "chi2", "open", "by");
}

void PrintVersionRow(const fleet::v1::MapVersion& v) {
  std::printf("%-4s %-4lld %-7s %-9s %-18s %-9s %7lld %7lld %5lld %9.1f %9.1f %5lld  %s\n",
              v.current() ? "*" : "", static_cast<long long>(v.version()),
              v.parent_version() > 0 ? std::to_string(v.parent_version()).c_str() : "-",
              Spelled(fleet::v1::MapOrigin_Name(v.version_origin()), "MAP_ORIGIN_").c_str(),
              Spelled(fleet::v1::MapAction_Name(v.version_action()), "MAP_ACTION_").c_str(),
              Spelled(fleet::v1::MapApproval_Name(v.approval_state()), "MAP_APPROVAL_").c_str(),
              static_cast<long long>(v.nodes()), static_cast<long long>(v.edges()),
              static_cast<long long>(v.components()), v.known_area_m2(), v.chi2(),
              static_cast<long long>(v.open_findings()), v.created_by().c_str());
}

void PrintFindings(const google::protobuf::RepeatedPtrField<fleet::v1::MapFinding>& findings) {
  if (findings.empty()) {
    std::printf("no findings\n");
    return;
  }
  for (const auto& f : findings) {
    std::printf("#%-3lld %-22s %-8s %.2f  %s\n", static_cast<long long>(f.finding_id()),
                Spelled(fleet::v1::FindingKind_Name(f.finding_kind()), "FINDING_KIND_").c_str(),
                Spelled(fleet::v1::FindingState_Name(f.finding_state()), "FINDING_STATE_").c_str(),
                f.severity(), f.summary().c_str());
  }
}

/// "FROM:TO" or "FROM:TO:VIEW".
bool ParseEdge(const std::string& text, fleet::v1::EdgeRef* edge) {
  long long from = 0, to = 0, view = 0;
  char tail = 0;
  const int fields = std::sscanf(text.c_str(), "%lld:%lld:%lld%c", &from, &to, &view, &tail);
  if (fields < 2 || fields > 3) return false;
  edge->set_from(from);
  edge->set_to(to);
  if (fields == 3) edge->set_view(view);
  return true;
}

bool WriteFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return static_cast<bool>(out);
}

}  // namespace

MapCommands::MapCommands(CLI::App& app) {
  maps_ = app.add_subcommand("maps", "robots' map history: findings, repairs, approval, hand-back, export");
  maps_->require_subcommand(1);
  robots_ = maps_->add_subcommand("robots", "robots with their map history in brief, a page at a time");
  robots_->add_option("--limit", page_size_, "robots per page (1..1000; default: the server's, 100)")
      ->check(CLI::Range(1, 1000));
  robots_->add_option("--after", after_robot_, "robots after this id (the previous page's last)");
  robots_->add_flag("--pending", only_pending_, "only robots with a version waiting for review");
  list_ = maps_->add_subcommand("list", "a robot's map versions");
  list_->add_option("robot", robot_, "robot id")->required();
  show_ = maps_->add_subcommand("show", "one version with its findings");
  show_->add_option("robot", robot_, "robot id")->required();
  show_->add_option("version", version_, "version (default: the current one)");
  repair_ = maps_->add_subcommand("repair", "make a repaired version of the robot's newest version");
  repair_->add_option("robot", robot_, "robot id")->required();
  repair_->add_option("--base", version_, "the version repaired (must be the newest)")->required();
  auto* edge =
      repair_->add_option("--reject-edge", reject_edge_, "FROM:TO[:VIEW]: remove one observation edge");
  auto* hypothesis = repair_->add_option("--reject-hypothesis", reject_hypothesis_,
                                         "remove a hypothesis's edges (undo a merge)");
  auto* cut = repair_->add_option(
      "--cut-finding", cut_finding_,
      "cut a protrusion (or an imported version's new_region) finding's region out of the map");
  auto* rollback =
      repair_->add_flag("--rollback", rollback_,
                        "back to the map before the version's run (imported versions: before the import)");
  auto* undo = repair_->add_flag("--undo", undo_, "undo the base version's repair");
  for (auto* option : {edge, hypothesis, cut, rollback, undo}) {
    for (auto* other : {edge, hypothesis, cut, rollback, undo}) {
      if (option != other) option->excludes(other);
    }
  }
  repair_->add_option("--reason", reason_, "why (kept with the version)");
  repair_->add_flag("--approve", approve_now_, "approve at once: the robot gets it on its next GetMap");
  approve_ = maps_->add_subcommand("approve", "approve a pending version");
  reject_ = maps_->add_subcommand("reject", "reject a pending version");
  for (auto* review : {approve_, reject_}) {
    review->add_option("robot", robot_, "robot id")->required();
    review->add_option("version", version_, "version")->required();
  }
  get_ = maps_->add_subcommand("get", "the map the robot would get (Maps.StreamMap: in parts, of any size)");
  get_->add_option("robot", robot_, "robot id")->required();
  get_->add_option("--held", held_, "the version the robot holds (0: none)");
  get_->add_option("--out", out_, "write the MapSnapshot bytes here");
  export_ =
      maps_->add_subcommand("export", "export a version as ROS map_server files, g2o or ValetudoMap JSON");
  export_->add_option("robot", robot_, "robot id")->required();
  export_->add_option("version", version_, "version (default: the current one)");
  export_->add_option("--format", format_, "map_server (PGM + YAML), g2o, or valetudo (ValetudoMap JSON)")
      ->required()
      ->check(CLI::IsMember({"map_server", "g2o", "valetudo"}));
  export_->add_option("--out", out_, "directory for the files (default: .)");
}

std::optional<int> MapCommands::Run(Client& client, const Global& global) const {
  if (!*maps_) return std::nullopt;
  if (*robots_) return Robots(client, global);
  if (*list_) return List(client, global);
  if (*show_) return Show(client, global);
  if (*repair_) return Repair(client, global);
  if (*approve_) return Review(client, global, true);
  if (*reject_) return Review(client, global, false);
  if (*get_) return Get(client, global);
  if (*export_) return Export(client, global);
  return 2;
}

int MapCommands::Robots(Client& client, const Global& global) const {
  fleet::v1::ListRobotsRequest request;
  request.set_page_size(page_size_);
  request.set_after_robot_id(after_robot_);
  request.set_only_pending(only_pending_);
  fleet::v1::ListRobotsResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.maps->ListRobots(context.get(), request, &response); !status.ok())
    return Fail(status);
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  std::printf("%-24s %-10s %-10s %8s %8s %8s %-9s %5s\n", "robot", "model", "firmware", "versions", "current",
              "pending", "newest", "open");
  for (const auto& robot : response.robots()) {
    std::printf("%-24s %-10s %-10s %8lld %8lld %8lld %-9s %5lld\n", robot.robot_id().c_str(),
                robot.robot_model().c_str(), robot.firmware().c_str(),
                static_cast<long long>(robot.versions()), static_cast<long long>(robot.current_version()),
                static_cast<long long>(robot.pending_versions()),
                Spelled(fleet::v1::MapApproval_Name(robot.newest_approval()), "MAP_APPROVAL_").c_str(),
                static_cast<long long>(robot.newest_open_findings()));
  }
  std::printf("%d of %lld robots%s\n", response.robots_size(), static_cast<long long>(response.total()),
              response.next_after_robot_id().empty()
                  ? ""
                  : ("; next page: --after " + response.next_after_robot_id()).c_str());
  return 0;
}

int MapCommands::List(Client& client, const Global& global) const {
  fleet::v1::ListMapVersionsRequest request;
  request.set_robot_id(robot_);
  fleet::v1::ListMapVersionsResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.maps->ListMapVersions(context.get(), request, &response); !status.ok())
    return Fail(status);
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  PrintVersionHeader();
  for (const auto& version : response.versions()) PrintVersionRow(version);
  std::printf("current version: %lld (* above)\n", static_cast<long long>(response.current_version()));
  return 0;
}

int MapCommands::Show(Client& client, const Global& global) const {
  fleet::v1::GetMapVersionRequest request;
  request.set_robot_id(robot_);
  request.set_version(version_);
  fleet::v1::GetMapVersionResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.maps->GetMapVersion(context.get(), request, &response); !status.ok())
    return Fail(status);
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  PrintVersionHeader();
  PrintVersionRow(response.version());
  if (!response.version().action_detail().empty())
    std::printf("repair: %s\n", response.version().action_detail().c_str());
  if (!response.version().reason().empty()) std::printf("reason: %s\n", response.version().reason().c_str());
  PrintFindings(response.findings());
  return 0;
}

int MapCommands::Repair(Client& client, const Global& global) const {
  fleet::v1::RepairMapRequest request;
  request.set_robot_id(robot_);
  request.set_base_version(version_);
  request.set_reason(reason_);
  request.set_approve(approve_now_);
  if (!reject_edge_.empty()) {
    if (!ParseEdge(reject_edge_, request.mutable_reject_edge())) {
      std::cerr << "fleetctl: --reject-edge: expected FROM:TO or FROM:TO:VIEW, got \"" << reject_edge_
                << "\"\n";
      return 2;
    }
  } else if (reject_hypothesis_ >= 0) {
    request.set_reject_hypothesis(reject_hypothesis_);
  } else if (cut_finding_ > 0) {
    request.set_cut_finding(cut_finding_);
  } else if (rollback_) {
    request.set_rollback(true);
  } else if (undo_) {
    request.set_undo(true);
  } else {
    std::cerr << "fleetctl: maps repair: give one of --reject-edge, --reject-hypothesis, --cut-finding, "
                 "--rollback, --undo\n";
    return 2;
  }
  fleet::v1::RepairMapResponse response;
  auto context = client.Context(300);
  if (grpc::Status status = client.maps->RepairMap(context.get(), request, &response); !status.ok())
    return Fail(status);
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  PrintVersionHeader();
  PrintVersionRow(response.version());
  std::printf("repair: %s\n", response.version().action_detail().c_str());
  PrintFindings(response.findings());
  return 0;
}

int MapCommands::Review(Client& client, const Global& global, bool approve) const {
  fleet::v1::ReviewMapVersionRequest request;
  request.set_robot_id(robot_);
  request.set_version(version_);
  request.set_approve(approve);
  fleet::v1::MapVersion response;
  auto context = client.Context();
  if (grpc::Status status = client.maps->ReviewMapVersion(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  PrintVersionHeader();
  PrintVersionRow(response);
  return 0;
}

int MapCommands::Get(Client& client, const Global& global) const {
  fleet::v1::GetMapRequest request;
  request.set_robot_id(robot_);
  request.set_held_version(held_);
  fleet::v1::GetMapResponse response;
  auto context = client.Context(120);
  if (grpc::Status status = fleet_client::ReceiveMap(*client.maps, *context, request,
                                                     fleet_client::kDefaultMaxMapBytes, &response);
      !status.ok())
    return Fail(status);
  if (!response.up_to_date() && !out_.empty() && !WriteFile(out_, response.snapshot().SerializeAsString())) {
    std::cerr << "fleetctl: cannot write " << out_ << "\n";
    return 1;
  }
  if (global.json) {
    fleet::v1::GetMapResponse summary = response;
    summary.clear_snapshot();  // the map itself goes to --out, not to the terminal
    PrintJson(summary);
    return 0;
  }
  if (response.up_to_date()) {
    std::printf("up to date: version %lld\n", static_cast<long long>(response.version().version()));
  } else {
    std::printf("version %lld: %d nodes, %d edges%s\n", static_cast<long long>(response.version().version()),
                response.snapshot().nodes_size(), response.snapshot().edges_size(),
                out_.empty() ? "" : (" → " + out_).c_str());
  }
  return 0;
}

int MapCommands::Export(Client& client, const Global& global) const {
  fleet::v1::ExportMapRequest request;
  request.set_robot_id(robot_);
  request.set_version(version_);
  request.set_format(format_);
  fleet::v1::ExportMapResponse response;
  auto context = client.Context(120);
  if (grpc::Status status = client.maps->ExportMap(context.get(), request, &response); !status.ok())
    return Fail(status);
  const std::filesystem::path directory = out_.empty() ? "." : out_;
  std::error_code ignored;
  std::filesystem::create_directories(directory, ignored);
  for (const auto& file : response.files()) {
    if (!WriteFile(directory / file.name(), file.content())) {
      std::cerr << "fleetctl: cannot write " << (directory / file.name()).string() << "\n";
      return 1;
    }
    if (!global.json)
      std::printf("%s (%zu bytes)\n", (directory / file.name()).string().c_str(), file.content().size());
  }
  if (global.json) {
    std::printf("{\"files\": [");
    for (int i = 0; i < response.files_size(); ++i) {
      std::printf("%s\"%s\"", i ? ", " : "", (directory / response.files(i).name()).string().c_str());
    }
    std::printf("]}\n");
  }
  return 0;
}

}  // namespace fleetctl
