#include "import_commands.h"

#include <cstdio>
#include <filesystem>

#include "analyzer/map_comparison.h"
#include "analyzer/telemetry_codec.h"
#include "analyzer/valetudo_map.h"
#include "slamcore/mapper.h"

namespace fleetctl {
namespace {

/// The file as a map-only snapshot (analyzer::ImportedSnapshot).
slamcore::Result<fleet::v1::MapSnapshot> ReadSnapshot(const std::string& path, bool valetudo) {
  if (!valetudo) {
    auto grid = slamcore::ReadMapServerYaml(path);
    if (!grid.ok()) return grid.status();
    return analyzer::ImportedSnapshot(*grid, "map_server", std::nullopt, std::nullopt);
  }
  auto map = analyzer::ReadValetudoMap(path);
  if (!map.ok()) return map.status();
  return analyzer::ImportedSnapshot(*map);
}

}  // namespace

ImportCommands::ImportCommands(CLI::App& app) {
  import_ = app.add_subcommand("import", "bring maps made elsewhere into a robot's map history (one version each)");
  import_->require_subcommand(1);
  valetudo_ = import_->add_subcommand("valetudo", "Valetudo map exports (JSON, or zlib-deflated JSON)");
  map_server_ = import_->add_subcommand("map-server", "ROS map_server maps (YAML + PGM/PNG)");
  for (CLI::App* command : {valetudo_, map_server_}) {
    command->add_option("files", files_, "files, imported in this order")->required()->check(CLI::ExistingFile);
    command->add_option("--robot", robot_, "the robot whose history gets the maps")->required();
    command->add_option("--reason", reason_, "why (kept with each version)");
    command->add_flag("--approve", approve_, "approve at once: the robot gets the last one on its next GetMap");
  }
}

std::optional<int> ImportCommands::Run(Client& client, const Global& global) const {
  if (!*import_) return std::nullopt;
  const bool valetudo = static_cast<bool>(*valetudo_);
  int imported = 0;
  for (const std::string& file : files_) {
    auto snapshot = ReadSnapshot(file, valetudo);
    if (!snapshot.ok()) {
      std::fprintf(stderr, "fleetctl: %s\n", snapshot.status().ToString().c_str());
      return 1;
    }
    fleet::v1::ImportMapRequest request;
    request.set_robot_id(robot_);
    *request.mutable_snapshot() = std::move(snapshot).value();
    request.set_source(std::string(valetudo ? "valetudo:" : "map_server:") +
                       std::filesystem::path(file).filename().string());
    request.set_reason(reason_);
    request.set_approve(approve_);
    fleet::v1::ImportMapResponse response;
    auto context = client.Context(120);
    if (grpc::Status status = client.maps->ImportMap(context.get(), request, &response); !status.ok()) {
      std::fprintf(stderr, "fleetctl: %s: ", file.c_str());
      return Fail(status);
    }
    ++imported;
    if (global.json) {
      PrintJson(response);
    } else {
      std::printf("%s → robot %s version %lld (%s, %.1f m² known)\n", file.c_str(), robot_.c_str(),
                  static_cast<long long>(response.version().version()), response.version().approval().c_str(),
                  response.version().known_area_m2());
    }
  }
  return imported == static_cast<int>(files_.size()) ? 0 : 1;
}

}  // namespace fleetctl
