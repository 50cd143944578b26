#include "import_commands.h"

#include <cstdio>
#include <filesystem>

#include "analyzer/import_order.h"
#include "analyzer/map_comparison.h"
#include "analyzer/map_metadata.h"
#include "analyzer/telemetry_codec.h"
#include "analyzer/valetudo_map.h"
#include "map_commands.h"
#include "slamcore/mapper.h"

namespace fleetctl {
namespace {

constexpr std::size_t kMaxFiles = 1000;

/// The file as a map-only snapshot with its metadata (the dashboard's upload makes the same).
slamcore::Result<analyzer::ImportedMap> ReadImport(const std::string& path, bool valetudo) {
  if (!valetudo) {
    ASSIGN_OR_RETURN(auto grid, slamcore::ReadMapServerYaml(path));
    return analyzer::ImportMapServer(grid);
  }
  ASSIGN_OR_RETURN(auto map, analyzer::ReadValetudoMap(path));
  return analyzer::ImportValetudo(map);
}

}  // namespace

ImportCommands::ImportCommands(CLI::App& app) {
  import_ =
      app.add_subcommand("import", "bring maps made elsewhere into a robot's map history (one version each)");
  import_->require_subcommand(1);
  valetudo_ = import_->add_subcommand("valetudo", "Valetudo map exports (JSON, or zlib-deflated JSON)");
  map_server_ = import_->add_subcommand("map-server", "ROS map_server maps (YAML + PGM/PNG)");
  for (CLI::App* command : {valetudo_, map_server_}) {
    command->add_option("files", files_, "files (at most 1000), imported in time order unless --order given")
        ->required()
        ->check(CLI::ExistingFile);
    command->add_option("--robot", robot_, "the robot whose history gets the maps")->required();
    command->add_option("--reason", reason_, "why (kept with each version)");
    command
        ->add_option(
            "--order", order_,
            "time: by the exports' own timestamps, else dates or numbers in the file names (default); "
            "given: as listed")
        ->check(CLI::IsMember({"time", "given"}));
    command->add_flag("--approve", approve_,
                      "approve at once: the robot gets the last one on its next GetMap");
  }
}

std::optional<int> ImportCommands::Run(Client& client, const Global& global) const {
  if (!*import_) return std::nullopt;
  const bool valetudo = static_cast<bool>(*valetudo_);
  // Every file is read first: the order needs their timestamps, and a bad file stops the series before it starts.
  if (files_.size() > kMaxFiles) {
    std::fprintf(stderr, "fleetctl: files: %zu files, more than %zu in one import; import them in batches\n",
                 files_.size(), kMaxFiles);
    return 2;
  }
  std::vector<analyzer::ImportedMap> maps;
  std::vector<analyzer::ImportFile> names;
  for (const std::string& file : files_) {
    auto map = ReadImport(file, valetudo);
    if (!map.ok()) {
      std::fprintf(stderr, "fleetctl: %s\n", map.status().ToString().c_str());
      return 1;
    }
    names.push_back({std::filesystem::path(file).filename().string(), map->own_time_ms});
    maps.push_back(std::move(map).value());
  }
  const analyzer::ImportOrder order = analyzer::OrderImports(names, order_ == "time");
  std::FILE* said = global.json ? stderr : stdout;  // --json keeps stdout to one object per version
  std::fprintf(said, "order: %s%s%s\n", order.basis.c_str(), order.note.empty() ? "" : " — ",
               order.note.c_str());
  for (std::size_t position = 0; position < order.order.size(); ++position) {
    std::fprintf(said, "  %zu. %s\n", position + 1, files_[order.order[position]].c_str());
  }
  int imported = 0;
  for (const std::size_t index : order.order) {
    const std::string& file = files_[index];
    fleet::v1::ImportMapRequest request;
    request.set_robot_id(robot_);
    *request.mutable_snapshot() = std::move(maps[index].snapshot);
    *request.mutable_metadata() = std::move(maps[index].metadata);
    request.set_source(std::string(valetudo ? "valetudo:" : "map_server:") +
                       std::filesystem::path(file).filename().string());
    request.set_reason(reason_);
    request.set_approve(approve_);
    fleet::v1::ImportMapResponse response;
    auto context = client.Context(120);
    if (grpc::Status status = client.maps->ImportMap(context.get(), request, &response); !status.ok()) {
      return Fail(status, file);
    }
    ++imported;
    if (global.json) {
      PrintJson(response);
    } else {
      std::printf(
          "%s → robot %s version %lld (%s, %.1f m² known)\n", file.c_str(), robot_.c_str(),
          static_cast<long long>(response.version().version()),
          Spelled(fleet::v1::MapApproval_Name(response.version().approval_state()), "MAP_APPROVAL_").c_str(),
          response.version().known_area_m2());
    }
  }
  return imported == static_cast<int>(files_.size()) ? 0 : 1;
}

}  // namespace fleetctl
