// What an imported map says besides its occupancy grid — rooms, the robot's path, robot and dock poses,
// virtual walls and zones (fleet::v1::MapMetadata, docs/formats/map-versions.md "Metadata of imported maps") —
// made from a ValetudoMap import, checked against bounds before it is stored, and written back with the grid
// as ValetudoMap JSON (the hand-back, docs/formats/valetudo.md).
//
// Error contract: ValidateMetadata and WriteValetudoMap return InvalidArgument naming the field
// ("metadata.zones: 5000 zones, more than the limit 1000"). Thread safety: pure functions.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "analyzer/map_comparison.h"
#include "analyzer/valetudo_map.h"
#include "fleet/v1/maps.pb.h"
#include "fleet/v1/telemetry.pb.h"
#include "slamcore/occupancy_grid.h"
#include "slamcore/status.h"

namespace analyzer {

/// Bounds on stored metadata; far above every real export (the largest has 18 rooms, 7 paths, 10404 path
/// coordinates), far below what would make a version costly to keep or draw.
struct MetadataLimits {
  std::size_t max_rooms = 256;
  std::size_t max_room_runs = 1'000'000;        // run coordinates (x, y, count) over all rooms
  std::size_t max_shapes = 1000;                // each of paths, virtual walls, zones
  std::size_t max_points = 1000;                // point entities
  std::size_t max_shape_coordinates = 200'000;  // over all paths, walls and zones
  std::size_t max_text = 256;                   // bytes of an id, name or type
  double max_abs_coordinate_m = 100'000.0;
  int max_pixel = 1'000'000;  // |map pixel coordinates| and run lengths of rooms
};

/// The metadata of a ValetudoMap import: its segments as rooms (id, name, pixels), paths, virtual walls,
/// zones and point entities (robot and dock among them).
fleet::v1::MapMetadata MetadataOf(const ValetudoMap& map);

/// Checks counts, lengths and values; OK for an empty message.
slamcore::Status ValidateMetadata(const fleet::v1::MapMetadata& metadata, const MetadataLimits& limits = {});

/// True when it carries anything (a format alone is nothing to keep).
bool HasContent(const fleet::v1::MapMetadata& metadata);

/// The robot and dock an imported snapshot carried, as metadata points (versions imported before metadata was
/// kept, and map_server imports, still hand these back).
fleet::v1::MapMetadata MetadataOfImported(const fleet::v1::ImportedMapInfo& imported);

/// A map made elsewhere as `fleetctl import` and the dashboard's upload send it to Maps.ImportMap /
/// MapHistory::Import: the snapshot (analyzer::ImportedSnapshot) and the metadata, with the export's own time.
struct ImportedMap {
  fleet::v1::MapSnapshot snapshot;
  fleet::v1::MapMetadata metadata;
  std::optional<std::int64_t> own_time_ms;  // the export's timestamp, when it has one
};
ImportedMap ImportValetudo(const ValetudoMap& map);
ImportedMap ImportMapServer(const slamcore::OccupancyGrid& grid);

/// Where a room's name goes: the mean of its pixels' centres, in metres; nullopt for a room without pixels.
std::optional<std::array<double, 2>> RoomCentre(const fleet::v1::MapRoom& room, double resolution);

/// Hand-back: `grid` as ValetudoMap JSON (metaData.version 2) that ParseValetudoMap reads back into the same
/// cells, with the metadata's rooms, entities and poses:
///  * pixelSize = the resolution in cm; grid cell (col, row) is map pixel (col + left, bottom − row) with
///    left = origin_x / s and bottom = −origin_y / s, shifted to keep pixels ≥ 0 (entities move with it);
///  * a segment layer per room of its pixels still known in the grid (a cut may have made some unknown; walls
///    win where a room overlaps one, as on import), a floor layer of the other free cells, a wall layer of the
///    occupied cells, each as compressedPixels runs with metaData.area in cm²;
///  * points, paths, virtual walls and zones as Point/Path/Line/PolygonMapEntity (cm, y down, angles in
///    degrees 0–359 on that screen).
/// INVALID_ARGUMENT naming the field when the grid is empty, has no known cell, a yaw, or a resolution that is
/// not a whole number of centimetres (1–100), or when the rooms' resolution differs from the grid's.
slamcore::Result<std::string> WriteValetudoMap(const slamcore::OccupancyGrid& grid,
                                               const fleet::v1::MapMetadata& metadata);

}  // namespace analyzer
