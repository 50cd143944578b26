// slamtool valetudo-to-map (see valetudo_command.h).
#include "valetudo_command.h"

#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "analyzer/valetudo_map.h"

namespace {

struct ValetudoArguments {
  std::string input;
  std::string output;
  bool png = false;
  bool json = false;
};

nlohmann::json PoseJson(const analyzer::ValetudoPose& pose) {
  nlohmann::json out = {{"type", pose.type}, {"x", pose.pose.x()}, {"y", pose.pose.y()}};
  if (pose.has_angle) out["theta"] = pose.pose.theta();
  return out;
}

nlohmann::json ShapesJson(const std::vector<analyzer::ValetudoShape>& shapes) {
  nlohmann::json out = nlohmann::json::array();
  for (const analyzer::ValetudoShape& shape : shapes) {
    nlohmann::json points = nlohmann::json::array();
    for (const auto& point : shape.points) points.push_back({point.x(), point.y()});
    out.push_back({{"type", shape.type}, {"points", points}});
  }
  return out;
}

nlohmann::json MapJson(const analyzer::ValetudoMap& map, const ValetudoArguments& arguments) {
  nlohmann::json layers = nlohmann::json::array();
  for (const analyzer::ValetudoLayer& layer : map.layers) {
    nlohmann::json entry = {
        {"type", layer.type}, {"pixels", layer.pixel_count}, {"area_m2", layer.area_cm2 / 1e4}};
    if (layer.declared_area_cm2) entry["declared_area_m2"] = *layer.declared_area_cm2 / 1e4;
    if (!layer.segment_id.empty()) entry["segment_id"] = layer.segment_id;
    if (!layer.name.empty()) entry["name"] = layer.name;
    layers.push_back(entry);
  }
  nlohmann::json out = {
      {"file", arguments.input},
      {"out", arguments.output},
      {"version", map.version},
      {"pixel_size_cm", map.pixel_size_cm},
      {"grid",
       {{"width", map.grid.width},
        {"height", map.grid.height},
        {"resolution", map.grid.resolution},
        {"origin", {map.grid.origin_x, map.grid.origin_y}}}},
      {"area_m2",
       {{"floor", map.AreaOf("floor") / 1e4},
        {"segment", map.AreaOf("segment") / 1e4},
        {"wall", map.AreaOf("wall") / 1e4}}},
      {"layers", layers},
      {"paths", ShapesJson(map.paths)},
      {"virtual_walls", ShapesJson(map.virtual_walls)},
      {"zones", ShapesJson(map.zones)},
  };
  if (map.robot) out["robot"] = PoseJson(*map.robot);
  if (map.dock) out["dock"] = PoseJson(*map.dock);
  nlohmann::json others = nlohmann::json::array();
  for (const analyzer::ValetudoPose& pose : map.other_points) others.push_back(PoseJson(pose));
  out["other_points"] = others;
  return out;
}

void PrintSummary(const analyzer::ValetudoMap& map, const ValetudoArguments& arguments) {
  std::printf("%s: ValetudoMap version %d, %d cm pixels -> %s (%d x %d cells at %.2f m)\n",
              arguments.input.c_str(), map.version, map.pixel_size_cm, arguments.output.c_str(),
              map.grid.width, map.grid.height, map.grid.resolution);
  std::printf("%-8s %-10s %-20s %10s %14s\n", "layer", "segment", "name", "area m²", "file's area m²");
  for (const analyzer::ValetudoLayer& layer : map.layers) {
    const std::string declared =
        layer.declared_area_cm2 ? std::to_string(*layer.declared_area_cm2 / 1e4) : "-";
    std::printf("%-8s %-10s %-20s %10.4f %14s\n", layer.type.c_str(), layer.segment_id.c_str(),
                layer.name.c_str(), layer.area_cm2 / 1e4, declared.c_str());
  }
  std::printf("floor %.2f m², rooms %.2f m², walls %.2f m²\n", map.AreaOf("floor") / 1e4,
              map.AreaOf("segment") / 1e4, map.AreaOf("wall") / 1e4);
  if (map.robot) std::printf("robot at (%.2f, %.2f) m\n", map.robot->pose.x(), map.robot->pose.y());
  if (map.dock) std::printf("dock at (%.2f, %.2f) m\n", map.dock->pose.x(), map.dock->pose.y());
  std::printf("%zu path(s), %zu virtual wall(s), %zu zone(s)\n", map.paths.size(), map.virtual_walls.size(),
              map.zones.size());
}

[[noreturn]] void Exit(int code) { throw CLI::RuntimeError(code); }

void RunValetudoToMap(const ValetudoArguments& arguments) {
  const auto map = analyzer::ReadValetudoMap(arguments.input);
  if (!map.ok()) {
    std::cerr << "slamtool: " << map.status().ToString() << "\n";
    Exit(1);
  }
  if (const auto status = slamcore::WriteMapServerYaml(map->grid, arguments.output, arguments.png);
      !status.ok()) {
    std::cerr << "slamtool: " << status.ToString() << "\n";
    Exit(1);
  }
  if (arguments.json) {
    std::cout << MapJson(*map, arguments).dump() << "\n";
  } else {
    PrintSummary(*map, arguments);
  }
  Exit(0);
}

}  // namespace

void AddValetudoCommands(CLI::App& app) {
  auto arguments = std::make_shared<ValetudoArguments>();
  CLI::App* command = app.add_subcommand(
      "valetudo-to-map",
      "import a Valetudo map export (JSON, or zlib-deflated JSON) as map_server YAML + PGM");
  command->add_option("FILE", arguments->input, "ValetudoMap JSON export")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--out", arguments->output, "map_server YAML to write (the image goes beside it)")
      ->required();
  command->add_flag("--png", arguments->png, "write the image as PNG instead of PGM");
  command->add_flag("--json", arguments->json, "print one JSON object on stdout");
  command->callback([arguments] { RunValetudoToMap(*arguments); });
}
