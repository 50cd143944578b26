// ValetudoMap import: a robot vacuum's map as Valetudo (open firmware for Roborock, Dreame, Viomi/3irobotix
// robots) exports it, read into slamcore's occupancy grid plus the map's rooms, path, poses and virtual
// restrictions. Format, units and axes: docs/formats/valetudo.md (our reading of Valetudo's
// backend/lib/entities/map/*.js and of real exports; no Valetudo code is used).
//
//  * Input: the JSON text (UI export or `GET /api/v2/robot/state/map`), or the same JSON zlib-deflated as
//    Valetudo publishes it over MQTT. metaData.version 1 or 2; layers with run-length `compressedPixels`
//    or expanded `pixels`.
//  * Grid: floor and segment pixels free, wall pixels occupied, everything else unknown; cropped to the
//    layers' bounding box plus a margin. Valetudo's y axis points down (screen), ours up: world x = px · s,
//    world y = −py · s with s = pixelSize / 100 m; the lower-left corner of pixel (px, py) is there.
//  * Metadata: rooms (segment layers with id and name), the path(s), the robot and dock poses, virtual
//    walls, no-go / no-mop / active zones and the rest of the entities, in metres in the same frame.
//
// Error contract: every problem with the input returns InvalidArgument naming the field (e.g.
// "layers[3].compressedPixels[7]: run leaves the map (x 6550 + count 9 > size.x 6554)"); every size is
// bounded (input bytes, inflated bytes, map side, pixels per layer, layers, entities, points).
// Thread safety: free functions without shared state.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "slamcore/occupancy_grid.h"
#include "slamcore/se2.h"
#include "slamcore/status.h"

namespace analyzer {

/// Limits on what an import accepts; the defaults are far above any real export.
struct ValetudoLimits {
  std::size_t max_input_bytes = 64u << 20;      // JSON or deflated bytes as read
  std::size_t max_inflated_bytes = 256u << 20;  // after zlib
  // JSON values (numbers, strings, …) and nesting, counted before the document is built: each value takes
  // some 16 bytes and more in memory, so 268 MB of "0," would take gigabytes. 32 million values hold a
  // v1 layer of 16 million pixels; a real export has a few hundred thousand.
  std::size_t max_json_values = 32'000'000;
  int max_json_depth = 64;
  int max_map_side = 20000;                    // size.x, size.y in map pixels (slamcore::kMaxGridSide)
  std::int64_t max_layer_pixels = 50'000'000;  // pixels one layer may cover
  // Pixels all layers together may cover (8 bytes each while decoding): without it, a thousand layers of
  // run-length rows, each within its own limit, would ask for hundreds of GB.
  std::int64_t max_total_pixels = 100'000'000;
  std::size_t max_layers = 1000;
  std::size_t max_entities = 10000;
  std::size_t max_points = 1'000'000;  // coordinates in one entity
  int grid_margin_px = 10;             // unknown border around the layers' bounding box
  // Cells of the grid the layers' bounding box (with the margin) spans: two pixels in opposite corners of
  // a large map make a grid of hundreds of MB from a file of a few hundred bytes. The default is the most
  // any grid may hold; fleetd's map upload takes far less (the largest real export we hold spans 0.6 M).
  std::int64_t max_grid_cells = slamcore::kMaxGridCells;
};

/// One layer: what it covers and what the file says about it.
struct ValetudoLayer {
  std::string type;                                    // "floor", "segment" or "wall"
  std::string segment_id;                              // segments: metaData.segmentId
  std::string name;                                    // segments: metaData.name when the user named the room
  std::int64_t pixel_count = 0;                        // distinct pixels the layer covers
  std::int64_t area_cm2 = 0;                           // pixel_count · pixelSize²
  std::optional<std::int64_t> declared_area_cm2;       // metaData.area as written in the file
  int min_px = 0, max_px = 0, min_py = 0, max_py = 0;  // bounding box in map pixels (when pixel_count > 0)
  std::vector<int> runs;  // segments: their pixels as runs along x (x, y, count, ...)
};

/// A point entity (robot, dock, go-to target, obstacle): metres, yaw in radians in our frame.
struct ValetudoPose {
  std::string type;
  slamcore::SE2 pose;
  bool has_angle = false;  // metaData.angle was present
};

/// A line, polygon or path entity: its points in metres, in our frame.
struct ValetudoShape {
  std::string type;  // e.g. "virtual_wall", "no_go_area", "path"
  std::vector<slamcore::Vector2> points;
};

struct ValetudoMap {
  int version = 0;                                      // metaData.version
  int pixel_size_cm = 0;                                // pixelSize
  int size_x = 0, size_y = 0;                           // size, in map pixels
  std::optional<std::int64_t> declared_total_area_cm2;  // metaData.totalLayerArea
  std::optional<std::int64_t>
      timestamp_ms;  // metaData.timestamp or timestamp (ISO 8601, or ms since the epoch)
  slamcore::OccupancyGrid grid;
  std::vector<ValetudoLayer> layers;       // in file order
  std::optional<ValetudoPose> robot;       // robot_position
  std::optional<ValetudoPose> dock;        // charger_location
  std::vector<ValetudoPose> other_points;  // go_to_target, obstacle, ...
  std::vector<ValetudoShape> paths;        // path and predicted_path
  std::vector<ValetudoShape> virtual_walls;
  std::vector<ValetudoShape> zones;  // no_go_area, no_mop_area, active_zone, carpet, ...

  /// Sum of the layers' areas of one type (cm²).
  std::int64_t AreaOf(std::string_view type) const;
};

/// Cells a map uploaded over the network (fleetd's map page) may decode to, whatever its format: a map_server
/// PNG inflates, a Valetudo export's pixel runs and far corners span far more than their bytes. The largest
/// real export we hold spans 0.6 million.
inline constexpr std::int64_t kMaxUploadedMapCells = 16'000'000;

/// What an upload over the network may hold, far less than a file on an engineer's disk: 32 MiB inflated, 4
/// million JSON values (a few hundred MB at most as a document), and pixels and the grid they span within
/// kMaxUploadedMapCells.
ValetudoLimits ValetudoUploadLimits();

/// Parses a ValetudoMap from JSON text or zlib-deflated JSON. `source` names the input in errors.
slamcore::Result<ValetudoMap> ParseValetudoMap(std::string_view bytes, const std::string& source,
                                               const ValetudoLimits& limits = {});

/// Reads and parses a file (see ParseValetudoMap).
slamcore::Result<ValetudoMap> ReadValetudoMap(const std::string& path, const ValetudoLimits& limits = {});

}  // namespace analyzer
