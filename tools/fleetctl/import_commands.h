// fleetctl import …: maps made elsewhere into a robot's map history (Maps.ImportMap), one version per file in
// the order given — e.g. a user's Valetudo exports after each cleaning become the history of one home.
//
//   import valetudo FILE.json... --robot R [--approve] [--reason TEXT]     (docs/formats/valetudo.md)
//   import map-server FILE.yaml... --robot R [--approve] [--reason TEXT]   (ROS map_server YAML + PGM/PNG)
//
// Each map becomes one fixed node at the origin whose local map is the whole occupancy grid. A file that does
// not read is refused before anything is sent (the message names the file and the field); the files before it
// stay imported. Exit status: 0 when every file was imported, 1 otherwise, 2 on usage.
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <vector>

#include "client.h"

namespace fleetctl {

class ImportCommands {
 public:
  /// Adds "import" and its subcommands to `app`.
  explicit ImportCommands(CLI::App& app);
  /// Runs the parsed subcommand; nullopt when "import" was not given.
  std::optional<int> Run(Client& client, const Global& global) const;

 private:
  CLI::App* import_ = nullptr;
  CLI::App *valetudo_ = nullptr, *map_server_ = nullptr;
  std::vector<std::string> files_;
  std::string robot_, reason_;
  bool approve_ = false;
};

}  // namespace fleetctl
