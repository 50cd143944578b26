// fleetctl import …: maps made elsewhere into a robot's map history (Maps.ImportMap), one version per file in
// time order — e.g. a user's Valetudo exports after each cleaning become the history of one home.
//
//   import valetudo FILE.json... --robot R [--order time|given] [--approve] [--reason TEXT]   (docs/formats/valetudo.md)
//   import map-server FILE.yaml... --robot R [--order time|given] [--approve] [--reason TEXT] (map_server YAML + PGM/PNG)
//
// Each map becomes one fixed node at the origin whose local map is the whole occupancy grid, with the export's
// rooms, path, poses, virtual walls and zones as the version's metadata. `--order time` (the default) imports
// by the exports' own timestamps, else dates or numbers in the file names, else as given
// (analyzer::OrderImports); the order used is printed first. Every file is read before anything is sent: one
// that does not read is refused (the message names the file and the field) and nothing is imported. Exit
// status: 0 when every file was imported, 1 otherwise, 2 on usage.
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
  std::string robot_, reason_, order_ = "time";
  bool approve_ = false;
};

}  // namespace fleetctl
