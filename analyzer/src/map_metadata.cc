#include "analyzer/map_metadata.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

namespace analyzer {
namespace {

using json = nlohmann::json;
using slamcore::InvalidArgument;
using slamcore::Status;

void AddShape(const ValetudoShape& shape, google::protobuf::RepeatedPtrField<fleet::v1::MapShape>* out) {
  fleet::v1::MapShape* added = out->Add();
  added->set_type(shape.type);
  for (const slamcore::Vector2& point : shape.points) {
    added->add_xy(point.x());
    added->add_xy(point.y());
  }
}

void AddPoint(const ValetudoPose& pose, fleet::v1::MapMetadata* out) {
  fleet::v1::MapPoint* point = out->add_points();
  point->set_type(pose.type);
  point->set_x(pose.pose.x());
  point->set_y(pose.pose.y());
  if (pose.has_angle) point->set_theta(pose.pose.theta());
}

Status CheckText(const std::string& text, const std::string& field, const MetadataLimits& limits) {
  if (text.size() > limits.max_text) {
    return InvalidArgument(field + ": " + std::to_string(text.size()) + " bytes, more than the limit " +
                           std::to_string(limits.max_text));
  }
  for (const char c : text) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      return InvalidArgument(field + ": holds a control character");
  }
  return Status::Ok();
}

Status CheckCoordinate(double value, const std::string& field, const MetadataLimits& limits) {
  if (!std::isfinite(value) || std::abs(value) > limits.max_abs_coordinate_m) {
    return InvalidArgument(field + ": not a finite coordinate within " +
                           std::to_string(limits.max_abs_coordinate_m) + " m");
  }
  return Status::Ok();
}

Status CheckCount(std::size_t count, std::size_t limit, const std::string& field, const char* what) {
  if (count > limit) {
    return InvalidArgument(field + ": " + std::to_string(count) + " " + what + ", more than the limit " +
                           std::to_string(limit));
  }
  return Status::Ok();
}

Status CheckRoom(const fleet::v1::MapRoom& room, const std::string& field, const MetadataLimits& limits) {
  RETURN_IF_ERROR(CheckText(room.segment_id(), field + ".segment_id", limits));
  RETURN_IF_ERROR(CheckText(room.name(), field + ".name", limits));
  if (room.runs_size() % 3 != 0)
    return InvalidArgument(field + ".runs: length is not a multiple of 3 (x, y, count)");
  std::int64_t pixels = 0;
  for (int i = 0; i < room.runs_size(); i += 3) {
    const int x = room.runs(i), y = room.runs(i + 1), count = room.runs(i + 2);
    const int bound = limits.max_pixel;
    if (x < -bound || y < -bound || x > bound || y > bound || count < 1 || count > bound) {
      return InvalidArgument(field + ".runs[" + std::to_string(i) + "]: run (" + std::to_string(x) + ", " +
                             std::to_string(y) + ", " + std::to_string(count) + ") is outside ±" +
                             std::to_string(bound) + " or empty");
    }
    pixels += count;
  }
  if (room.pixel_count() < 0 || room.pixel_count() > pixels) {
    return InvalidArgument(field + ".pixel_count: " + std::to_string(room.pixel_count()) +
                           " is not within the runs' " + std::to_string(pixels) + " pixels");
  }
  if (!std::isfinite(room.area_m2()) || room.area_m2() < 0 || room.area_m2() > 1e8) {
    return InvalidArgument(field + ".area_m2: not a finite area ≥ 0");
  }
  return Status::Ok();
}

Status CheckShapes(const google::protobuf::RepeatedPtrField<fleet::v1::MapShape>& shapes,
                   const std::string& field, int min_points, const MetadataLimits& limits,
                   std::size_t* coordinates) {
  RETURN_IF_ERROR(CheckCount(static_cast<std::size_t>(shapes.size()), limits.max_shapes, field, "shapes"));
  for (int i = 0; i < shapes.size(); ++i) {
    const fleet::v1::MapShape& shape = shapes[i];
    const std::string at = field + "[" + std::to_string(i) + "]";
    RETURN_IF_ERROR(CheckText(shape.type(), at + ".type", limits));
    if (shape.type().empty()) return InvalidArgument(at + ".type: empty");
    if (shape.xy_size() % 2 != 0) return InvalidArgument(at + ".xy: length is not a multiple of 2 (x, y)");
    if (shape.xy_size() / 2 < min_points) {
      return InvalidArgument(at + ".xy: " + std::to_string(shape.xy_size() / 2) + " points, fewer than " +
                             std::to_string(min_points));
    }
    *coordinates += static_cast<std::size_t>(shape.xy_size());
    RETURN_IF_ERROR(CheckCount(*coordinates, limits.max_shape_coordinates,
                               field.substr(0, field.find('.')) + ".paths+virtual_walls+zones",
                               "coordinates"));
    for (int k = 0; k < shape.xy_size(); ++k) {
      RETURN_IF_ERROR(CheckCoordinate(shape.xy(k), at + ".xy[" + std::to_string(k) + "]", limits));
    }
  }
  return Status::Ok();
}

/// Map pixel ↔ grid cell of the hand-back, and the shift that keeps pixels ≥ 0.
struct PixelFrame {
  double resolution = 0.0;
  int left = 0, bottom = 0;      // pixel of cell (0, row) is left; of row r, bottom − r (before the shift)
  int shift_x = 0, shift_y = 0;  // added to every pixel written
};

/// Runs along x of the cells for which `keep(col, row)` holds, as compressedPixels; returns the cell count.
template <typename Keep>
std::int64_t AppendRuns(const slamcore::OccupancyGrid& grid, const PixelFrame& frame, int row, Keep keep,
                        json& runs) {
  std::int64_t count = 0;
  for (int col = 0; col < grid.width;) {
    if (!keep(col, row)) {
      ++col;
      continue;
    }
    int end = col;
    while (end < grid.width && keep(end, row)) ++end;
    runs.push_back(col + frame.left + frame.shift_x);
    runs.push_back(frame.bottom - row + frame.shift_y);
    runs.push_back(end - col);
    count += end - col;
    col = end;
  }
  return count;
}

json Layer(const char* type, json pixels, std::int64_t count, std::int64_t pixel_area,
           json meta = json::object()) {
  meta["area"] = count * pixel_area;
  return json{{"__class", "MapLayer"},
              {"type", type},
              {"compressedPixels", std::move(pixels)},
              {"metaData", std::move(meta)}};
}

}  // namespace

fleet::v1::MapMetadata MetadataOf(const ValetudoMap& map) {
  fleet::v1::MapMetadata metadata;
  metadata.set_format("valetudo");
  metadata.set_resolution(map.pixel_size_cm / 100.0);
  for (const ValetudoLayer& layer : map.layers) {
    if (layer.type != "segment") continue;
    fleet::v1::MapRoom* room = metadata.add_rooms();
    room->set_segment_id(layer.segment_id);
    room->set_name(layer.name);
    room->set_pixel_count(layer.pixel_count);
    room->set_area_m2(static_cast<double>(layer.area_cm2) / 1e4);
    room->mutable_runs()->Add(layer.runs.begin(), layer.runs.end());
  }
  for (const ValetudoShape& path : map.paths) AddShape(path, metadata.mutable_paths());
  for (const ValetudoShape& wall : map.virtual_walls) AddShape(wall, metadata.mutable_virtual_walls());
  for (const ValetudoShape& zone : map.zones) AddShape(zone, metadata.mutable_zones());
  if (map.robot) AddPoint(*map.robot, &metadata);
  if (map.dock) AddPoint(*map.dock, &metadata);
  for (const ValetudoPose& other : map.other_points) AddPoint(other, &metadata);
  return metadata;
}

ImportedMap ImportValetudo(const ValetudoMap& map) {
  return {ImportedSnapshot(map), MetadataOf(map), map.timestamp_ms};
}

ImportedMap ImportMapServer(const slamcore::OccupancyGrid& grid) {
  ImportedMap imported{ImportedSnapshot(grid, "map_server", std::nullopt, std::nullopt), {}, std::nullopt};
  imported.metadata.set_format("map_server");
  return imported;
}

bool HasContent(const fleet::v1::MapMetadata& metadata) {
  return metadata.rooms_size() + metadata.paths_size() + metadata.virtual_walls_size() +
             metadata.zones_size() + metadata.points_size() >
         0;
}

Status ValidateMetadata(const fleet::v1::MapMetadata& metadata, const MetadataLimits& limits) {
  RETURN_IF_ERROR(CheckText(metadata.format(), "metadata.format", limits));
  if (!metadata.format().empty() && metadata.format() != "valetudo" && metadata.format() != "map_server") {
    return InvalidArgument("metadata.format: \"" + metadata.format() +
                           "\", expected \"valetudo\" or \"map_server\"");
  }
  RETURN_IF_ERROR(CheckCount(static_cast<std::size_t>(metadata.rooms_size()), limits.max_rooms,
                             "metadata.rooms", "rooms"));
  if (metadata.rooms_size() > 0 && !(metadata.resolution() >= 0.005 && metadata.resolution() <= 1.0)) {
    return InvalidArgument("metadata.resolution: " + std::to_string(metadata.resolution()) +
                           " m per pixel is outside [0.005, 1] (the rooms' pixels need it)");
  }
  std::size_t runs = 0;
  for (int i = 0; i < metadata.rooms_size(); ++i) {
    runs += static_cast<std::size_t>(metadata.rooms(i).runs_size());
    RETURN_IF_ERROR(CheckCount(runs, limits.max_room_runs, "metadata.rooms", "run coordinates"));
    RETURN_IF_ERROR(CheckRoom(metadata.rooms(i), "metadata.rooms[" + std::to_string(i) + "]", limits));
  }
  std::size_t coordinates = 0;
  RETURN_IF_ERROR(CheckShapes(metadata.paths(), "metadata.paths", 0, limits, &coordinates));
  RETURN_IF_ERROR(CheckShapes(metadata.virtual_walls(), "metadata.virtual_walls", 2, limits, &coordinates));
  RETURN_IF_ERROR(CheckShapes(metadata.zones(), "metadata.zones", 3, limits, &coordinates));
  RETURN_IF_ERROR(CheckCount(static_cast<std::size_t>(metadata.points_size()), limits.max_points,
                             "metadata.points", "points"));
  for (int i = 0; i < metadata.points_size(); ++i) {
    const fleet::v1::MapPoint& point = metadata.points(i);
    const std::string at = "metadata.points[" + std::to_string(i) + "]";
    RETURN_IF_ERROR(CheckText(point.type(), at + ".type", limits));
    if (point.type().empty()) return InvalidArgument(at + ".type: empty");
    RETURN_IF_ERROR(CheckCoordinate(point.x(), at + ".x", limits));
    RETURN_IF_ERROR(CheckCoordinate(point.y(), at + ".y", limits));
    if (point.has_theta() && !std::isfinite(point.theta())) return InvalidArgument(at + ".theta: not finite");
  }
  return Status::Ok();
}

fleet::v1::MapMetadata MetadataOfImported(const fleet::v1::ImportedMapInfo& imported) {
  fleet::v1::MapMetadata metadata;
  metadata.set_format(imported.format());
  for (const auto& [type, has, pose] :
       {std::tuple{"robot_position", imported.has_robot(), imported.robot()},
        std::tuple{"charger_location", imported.has_dock(), imported.dock()}}) {
    if (!has) continue;
    fleet::v1::MapPoint* point = metadata.add_points();
    point->set_type(type);
    point->set_x(pose.x());
    point->set_y(pose.y());
    point->set_theta(pose.theta());
  }
  return metadata;
}

std::optional<std::array<double, 2>> RoomCentre(const fleet::v1::MapRoom& room, double resolution) {
  double sum_x = 0.0, sum_y = 0.0, pixels = 0.0;
  for (int i = 0; i + 2 < room.runs_size(); i += 3) {
    const double count = room.runs(i + 2);
    sum_x += count * (room.runs(i) + (count - 1) / 2.0 + 0.5);
    sum_y +=
        count * (room.runs(i + 1) - 0.5);  // pixel y covers world y ∈ (−(y)·s … −(y−1)·s]: centre −(y − ½)·s
    pixels += count;
  }
  if (pixels == 0.0) return std::nullopt;
  return std::array<double, 2>{sum_x / pixels * resolution, -sum_y / pixels * resolution};
}

slamcore::Result<std::string> WriteValetudoMap(const slamcore::OccupancyGrid& grid,
                                               const fleet::v1::MapMetadata& metadata) {
  if (grid.width <= 0 || grid.height <= 0) return InvalidArgument("grid: empty, nothing to hand back");
  if (grid.origin_yaw != 0.0)
    return InvalidArgument("grid.origin_yaw: a rotated grid has no Valetudo pixels");
  const double cm = grid.resolution * 100.0;
  const int pixel_size = static_cast<int>(std::lround(cm));
  if (pixel_size < 1 || pixel_size > 100 || std::abs(cm - pixel_size) > 1e-6) {
    return InvalidArgument("grid.resolution: " + std::to_string(grid.resolution) +
                           " m is not a whole number of centimetres in 1–100 (Valetudo's pixelSize)");
  }
  if (metadata.rooms_size() > 0 && std::abs(metadata.resolution() - grid.resolution) > 1e-9) {
    return InvalidArgument("metadata.resolution: " + std::to_string(metadata.resolution()) +
                           " m differs from the grid's " + std::to_string(grid.resolution) + " m");
  }
  // Pixel (px, py) has its lower-left corner at (px·s, −py·s) (the import's frame); a map whose origin is not
  // on that lattice, or lies at negative pixels, is shifted to the nearest lattice point ≥ 0.
  PixelFrame frame;
  frame.resolution = grid.resolution;
  frame.left = static_cast<int>(std::lround(grid.origin_x / grid.resolution));
  frame.bottom = static_cast<int>(std::lround(-grid.origin_y / grid.resolution));
  frame.shift_x = frame.left < 0 ? -frame.left : 0;
  frame.shift_y = frame.bottom - (grid.height - 1) < 0 ? (grid.height - 1) - frame.bottom : 0;
  const std::int64_t pixel_area = static_cast<std::int64_t>(pixel_size) * pixel_size;
  const auto known = [&](int col, int row) {
    return grid.at(col, row) != static_cast<std::int8_t>(slamcore::CellState::kUnknown);
  };

  // Rooms: their pixels that are still known cells of this grid.
  std::vector<char> in_room(grid.cells.size(), 0);
  json layers = json::array();
  std::int64_t total = 0;
  for (const fleet::v1::MapRoom& room : metadata.rooms()) {
    std::vector<char> mine(grid.cells.size(), 0);
    for (int i = 0; i + 2 < room.runs_size(); i += 3) {
      const int row = frame.bottom - room.runs(i + 1);
      if (row < 0 || row >= grid.height) continue;
      for (int k = 0; k < room.runs(i + 2); ++k) {
        const int col = room.runs(i) + k - frame.left;
        if (col < 0 || col >= grid.width || !known(col, row)) continue;
        mine[static_cast<std::size_t>(row) * grid.width + col] = 1;
      }
    }
    json runs = json::array();
    std::int64_t count = 0;
    for (int row = grid.height - 1; row >= 0; --row) {
      count += AppendRuns(
          grid, frame, row,
          [&](int col, int r) { return mine[static_cast<std::size_t>(r) * grid.width + col] != 0; }, runs);
    }
    if (count == 0) continue;  // cut away entirely: no layer (Valetudo refuses empty ones)
    for (std::size_t i = 0; i < mine.size(); ++i) in_room[i] |= mine[i];
    json meta = {{"segmentId", room.segment_id()}, {"active", false}};
    if (!room.name().empty()) meta["name"] = room.name();
    layers.push_back(Layer("segment", std::move(runs), count, pixel_area, std::move(meta)));
    total += count;
  }
  json floor = json::array(), walls = json::array();
  std::int64_t free_count = 0, wall_count = 0;
  const auto state_is = [&](slamcore::CellState state) {
    return [&grid, state](int col, int row) { return grid.at(col, row) == static_cast<std::int8_t>(state); };
  };
  const auto is_free = state_is(slamcore::CellState::kFree),
             is_wall = state_is(slamcore::CellState::kOccupied);
  for (int row = grid.height - 1; row >= 0; --row) {  // py ascending
    free_count += AppendRuns(
        grid, frame, row,
        [&](int col, int r) {
          return is_free(col, r) && !in_room[static_cast<std::size_t>(r) * grid.width + col];
        },
        floor);
    wall_count += AppendRuns(grid, frame, row, is_wall, walls);
  }
  if (free_count + wall_count + total == 0)
    return InvalidArgument("grid: no free or occupied cell, nothing to hand back");
  if (free_count) layers.insert(layers.begin(), Layer("floor", std::move(floor), free_count, pixel_area));
  if (wall_count) layers.push_back(Layer("wall", std::move(walls), wall_count, pixel_area));
  total += free_count + wall_count;

  // Entity points are cm with y down; angles degrees 0–359 on that screen (the inverse of the import's).
  const auto cm_x = [&](double x) { return std::lround((x + frame.shift_x * grid.resolution) * 100.0); };
  const auto cm_y = [&](double y) { return std::lround((-y + frame.shift_y * grid.resolution) * 100.0); };
  json entities = json::array();
  for (const fleet::v1::MapPoint& point : metadata.points()) {
    json entity = {{"__class", "PointMapEntity"},
                   {"type", point.type()},
                   {"points", {cm_x(point.x()), cm_y(point.y())}}};
    if (point.has_theta()) {
      entity["metaData"] = {
          {"angle", ((std::lround(-point.theta() * 180.0 / std::numbers::pi) % 360) + 360) % 360}};
    }
    entities.push_back(std::move(entity));
  }
  for (const auto& [kind, shapes] :
       {std::pair{"PathMapEntity", &metadata.paths()}, std::pair{"LineMapEntity", &metadata.virtual_walls()},
        std::pair{"PolygonMapEntity", &metadata.zones()}}) {
    for (const fleet::v1::MapShape& shape : *shapes) {
      json points = json::array();
      for (int i = 0; i + 1 < shape.xy_size(); i += 2) {
        points.push_back(cm_x(shape.xy(i)));
        points.push_back(cm_y(shape.xy(i + 1)));
      }
      entities.push_back({{"__class", kind}, {"type", shape.type()}, {"points", std::move(points)}});
    }
  }
  const json map{
      {"__class", "ValetudoMap"},
      {"metaData", {{"version", 2}, {"totalLayerArea", total * pixel_area}}},
      {"size", {{"x", frame.left + frame.shift_x + grid.width}, {"y", frame.bottom + frame.shift_y + 1}}},
      {"pixelSize", pixel_size},
      {"layers", std::move(layers)},
      {"entities", std::move(entities)}};
  return map.dump();
}

}  // namespace analyzer
