// slamtool subcommand importing a Valetudo map export (docs/formats/valetudo.md):
//
//   slamtool valetudo-to-map FILE.json --out OUT.yaml [--png] [--json]
//
// Writes the occupancy grid as ROS map_server YAML + PGM (or PNG) and prints each layer's area (m², and the
// file's own metaData.area beside it), the rooms, the robot and dock poses, virtual walls and zones; --json
// prints one JSON object with all of it instead. Exit status: 0 on success, 1 when the input is refused (the
// message names the field), 2 on usage.
#pragma once

#include <CLI/CLI.hpp>

void AddValetudoCommands(CLI::App& app);
