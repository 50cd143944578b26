// ValetudoMap import (docs/formats/valetudo.md). The structure follows Valetudo's map entities as read in
// github.com/Hypfer/Valetudo backend/lib/entities/map/ (ValetudoMap.js, MapLayer.js, *MapEntity.js): layers
// of map pixels (`pixels` [x, y, ...] or run-length `compressedPixels` [x, y, count, ...] along x), entities
// with points in cm. Only the format is taken from there; this is our own reader.
#include "analyzer/valetudo_map.h"

#include "analyzer/import_order.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>

namespace analyzer {
namespace {

using json = nlohmann::json;
using slamcore::InvalidArgument;
using slamcore::Status;

/// The shape of a JSON text, read without building it (nlohmann's SAX interface): it stops at the first
/// value past `max_values` or level past `max_depth`, so a text that would take gigabytes as a document is
/// refused having cost nothing but the scan.
class JsonShapeCheck {
 public:
  JsonShapeCheck(std::size_t max_values, int max_depth) : max_values_(max_values), max_depth_(max_depth) {}

  bool null() { return Value(); }
  bool boolean(bool) { return Value(); }
  bool number_integer(json::number_integer_t) { return Value(); }
  bool number_unsigned(json::number_unsigned_t) { return Value(); }
  bool number_float(json::number_float_t, const json::string_t&) { return Value(); }
  bool string(json::string_t&) { return Value(); }
  bool binary(json::binary_t&) { return Value(); }
  bool start_object(std::size_t) { return Open(); }
  bool key(json::string_t&) { return true; }
  bool end_object() { return Close(); }
  bool start_array(std::size_t) { return Open(); }
  bool end_array() { return Close(); }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) { return false; }

  /// Why the scan stopped, or nothing when the text is within the bounds (or not JSON: the parse says so).
  std::optional<std::string> Refusal() const {
    if (too_deep_) return "nests deeper than " + std::to_string(max_depth_) + " levels";
    if (too_many_) return "holds more than " + std::to_string(max_values_) + " JSON values";
    return std::nullopt;
  }

 private:
  bool Value() {
    too_many_ = ++values_ > max_values_;
    return !too_many_;
  }
  bool Open() {
    too_deep_ = ++depth_ > max_depth_;
    return !too_deep_ && Value();
  }
  bool Close() {
    --depth_;
    return true;
  }

  std::size_t max_values_, values_ = 0;
  int max_depth_, depth_ = 0;
  bool too_many_ = false, too_deep_ = false;
};

/// zlib stream header (RFC 1950): CMF 0x78 and a check byte making CMF·256 + FLG a multiple of 31.
bool LooksDeflated(std::string_view bytes) {
  if (bytes.size() < 2) return false;
  const auto cmf = static_cast<unsigned char>(bytes[0]), flg = static_cast<unsigned char>(bytes[1]);
  return (cmf & 0x0F) == 8 && (cmf * 256 + flg) % 31 == 0;
}

slamcore::Result<std::string> Inflate(std::string_view bytes, const std::string& source, std::size_t limit) {
  z_stream stream{};
  if (inflateInit(&stream) != Z_OK) return slamcore::Internal("zlib inflateInit failed");
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  stream.avail_in = static_cast<uInt>(bytes.size());
  std::string out;
  char buffer[1 << 16];
  int code = Z_OK;
  while (code == Z_OK) {
    stream.next_out = reinterpret_cast<Bytef*>(buffer);
    stream.avail_out = sizeof(buffer);
    code = inflate(&stream, Z_NO_FLUSH);
    out.append(buffer, sizeof(buffer) - stream.avail_out);
    if (out.size() > limit) {
      inflateEnd(&stream);
      return InvalidArgument(source + ": deflated map inflates to more than " + std::to_string(limit) +
                             " bytes");
    }
    if (code == Z_BUF_ERROR && stream.avail_in == 0) break;  // input ended before the stream did
  }
  inflateEnd(&stream);
  if (code != Z_STREAM_END) {
    return InvalidArgument(source + ": zlib stream is corrupt or truncated (" +
                           (stream.msg ? stream.msg : "no message") + ")");
  }
  return out;
}

/// An integer JSON value as int64: one past its range (unsigned, up to 2⁶⁴ − 1) saturates to its maximum, so
/// that range checks refuse it; messages print the file's own text (`dump()`), not a wrapped number.
std::int64_t SaturatedInt(const json& value) {
  if (value.is_number_unsigned() &&
      value.get<std::uint64_t>() > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
    return std::numeric_limits<std::int64_t>::max();
  }
  return value.get<std::int64_t>();
}

/// Reads field `key` of `object` as an integer in [lo, hi]; `where` names the object in errors.
slamcore::Result<std::int64_t> IntField(const json& object, const char* key, const std::string& where,
                                        std::int64_t lo, std::int64_t hi) {
  const auto it = object.find(key);
  if (it == object.end()) return InvalidArgument(where + "." + key + ": missing");
  if (!it->is_number_integer()) return InvalidArgument(where + "." + key + ": not an integer");
  const std::int64_t value = SaturatedInt(*it);
  if (value < lo || value > hi) {
    return InvalidArgument(where + "." + key + ": " + it->dump() + " is outside [" + std::to_string(lo) +
                           ", " + std::to_string(hi) + "]");
  }
  return value;
}

std::optional<std::int64_t> OptionalInt(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_number_integer()) return std::nullopt;
  return SaturatedInt(*it);
}

std::string OptionalString(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end()) return {};
  if (it->is_string()) return it->get<std::string>();
  if (it->is_number_integer()) return it->dump();
  return {};
}

/// How many pixels a layer may still cover: the lesser of its own limit and what the layers before it left
/// of the limit on all layers together (each pixel is 8 bytes while the layers are decoded).
struct PixelBudget {
  std::int64_t pixels = 0;
  bool by_total = false;  // the limit on all layers together is the lesser one
  std::int64_t limit = 0;

  static PixelBudget For(const ValetudoLimits& limits, std::int64_t covered_so_far) {
    const std::int64_t left = std::max<std::int64_t>(0, limits.max_total_pixels - covered_so_far);
    if (left < limits.max_layer_pixels) return {left, true, limits.max_total_pixels};
    return {limits.max_layer_pixels, false, limits.max_layer_pixels};
  }
  std::string Describe() const {
    if (!by_total) return "the limit of " + std::to_string(limit) + " pixels a layer may cover";
    return "the " + std::to_string(pixels) + " pixels left of the " + std::to_string(limit) +
           " all layers together may cover";
  }
};

/// A layer's pixels, decoded and checked against the map's size, as a set of cell indices.
class LayerPixels {
 public:
  LayerPixels(int size_x, int size_y) : size_x_(size_x), size_y_(size_y) {}

  /// `pixels`: [x, y, x, y, ...]; at most `budget.pixels` of them.
  Status AddExpanded(const json& array, const std::string& where, const PixelBudget& budget) {
    if (array.size() % 2 != 0) {
      return InvalidArgument(where + ": length " + std::to_string(array.size()) +
                             " is not a multiple of 2 (x, y pairs)");
    }
    if (static_cast<std::int64_t>(array.size() / 2) > budget.pixels) {
      return InvalidArgument(where + ": " + std::to_string(array.size() / 2) + " pixels, more than " +
                             budget.Describe());
    }
    for (std::size_t i = 0; i < array.size(); i += 2) {
      int x = 0, y = 0;
      RETURN_IF_ERROR(Coordinate(array[i], where, i, size_x_, "size.x", &x));
      RETURN_IF_ERROR(Coordinate(array[i + 1], where, i + 1, size_y_, "size.y", &y));
      cells_.push_back(static_cast<std::int64_t>(y) * size_x_ + x);
    }
    return Status::Ok();
  }

  /// `compressedPixels`: [x, y, count, ...], each run covering (x .. x + count − 1, y); at most
  /// `budget.pixels` in all, checked before a run is expanded (a run of 3 numbers may cover 20,000 pixels).
  Status AddCompressed(const json& array, const std::string& where, const PixelBudget& budget) {
    if (array.size() % 3 != 0) {
      return InvalidArgument(where + ": length " + std::to_string(array.size()) +
                             " is not a multiple of 3 (x, y, count runs): truncated?");
    }
    std::int64_t total = 0;
    for (std::size_t i = 0; i < array.size(); i += 3) {
      int x = 0, y = 0;
      RETURN_IF_ERROR(Coordinate(array[i], where, i, size_x_, "size.x", &x));
      RETURN_IF_ERROR(Coordinate(array[i + 1], where, i + 1, size_y_, "size.y", &y));
      const json& count_value = array[i + 2];
      const std::string at = where + "[" + std::to_string(i + 2) + "]";
      if (!count_value.is_number_integer()) return InvalidArgument(at + ": run length is not an integer");
      const std::int64_t count = SaturatedInt(count_value);
      if (count < 1) return InvalidArgument(at + ": run length " + count_value.dump() + " < 1");
      if (count > size_x_ - x) {
        return InvalidArgument(at + ": run leaves the map (x " + std::to_string(x) + " + count " +
                               count_value.dump() + " > size.x " + std::to_string(size_x_) + ")");
      }
      total += count;
      if (total > budget.pixels) return InvalidArgument(where + ": more than " + budget.Describe());
      for (std::int64_t k = 0; k < count; ++k)
        cells_.push_back(static_cast<std::int64_t>(y) * size_x_ + x + k);
    }
    return Status::Ok();
  }

  /// The distinct cells, sorted (Valetudo's own layers never repeat a pixel; a file that does is counted once).
  const std::vector<std::int64_t>& Cells() {
    std::sort(cells_.begin(), cells_.end());
    cells_.erase(std::unique(cells_.begin(), cells_.end()), cells_.end());
    return cells_;
  }

 private:
  static Status Coordinate(const json& value, const std::string& where, std::size_t index, int bound,
                           const char* bound_name, int* out) {
    const std::string at = where + "[" + std::to_string(index) + "]";
    if (!value.is_number_integer()) return InvalidArgument(at + ": not an integer");
    const std::int64_t v = SaturatedInt(value);
    if (v < 0 || v >= bound) {
      return InvalidArgument(at + ": " + value.dump() + " is outside the map [0, " + bound_name + " " +
                             std::to_string(bound) + ")");
    }
    *out = static_cast<int>(v);
    return Status::Ok();
  }

  int size_x_, size_y_;
  std::vector<std::int64_t> cells_;
};

struct DecodedLayer {
  ValetudoLayer layer;
  std::vector<std::int64_t> cells;
};

slamcore::Result<DecodedLayer> DecodeLayer(const json& value, std::size_t index, const ValetudoMap& map,
                                           const PixelBudget& budget) {
  const std::string where = "layers[" + std::to_string(index) + "]";
  if (!value.is_object()) return InvalidArgument(where + ": not an object");
  DecodedLayer decoded;
  ValetudoLayer& layer = decoded.layer;
  const auto type = value.find("type");
  if (type == value.end() || !type->is_string())
    return InvalidArgument(where + ".type: missing or not a string");
  layer.type = type->get<std::string>();
  if (layer.type != "floor" && layer.type != "segment" && layer.type != "wall") {
    return InvalidArgument(where + ".type: unknown layer type \"" + layer.type +
                           "\" (floor, segment or wall)");
  }
  const json empty = json::object();
  const auto meta_it = value.find("metaData");
  const json& meta = meta_it != value.end() && meta_it->is_object() ? *meta_it : empty;
  layer.segment_id = OptionalString(meta, "segmentId");
  layer.name = OptionalString(meta, "name");
  layer.declared_area_cm2 = OptionalInt(meta, "area");

  LayerPixels pixels(map.size_x, map.size_y);
  const auto compressed = value.find("compressedPixels");
  const auto expanded = value.find("pixels");
  const bool has_compressed = compressed != value.end() && compressed->is_array();
  const bool has_expanded = expanded != value.end() && expanded->is_array() && !expanded->empty();
  if (has_compressed && has_expanded && !compressed->empty()) {
    return InvalidArgument(where + ": both pixels and compressedPixels are set; a layer has one encoding");
  }
  if (has_compressed && !has_expanded) {
    if (Status status = pixels.AddCompressed(*compressed, where + ".compressedPixels", budget);
        !status.ok()) {
      return status;
    }
  } else if (expanded != value.end() && expanded->is_array()) {
    if (Status status = pixels.AddExpanded(*expanded, where + ".pixels", budget); !status.ok()) {
      return status;
    }
  } else {
    return InvalidArgument(where + ": neither pixels nor compressedPixels is an array");
  }
  decoded.cells = pixels.Cells();
  // Valetudo refuses to build a layer without pixels (MapLayer.js), so an empty one is a broken file.
  if (decoded.cells.empty())
    return InvalidArgument(where + ": no pixels (pixels and compressedPixels are empty)");
  layer.pixel_count = static_cast<std::int64_t>(decoded.cells.size());
  layer.area_cm2 = layer.pixel_count * map.pixel_size_cm * map.pixel_size_cm;
  if (!decoded.cells.empty()) {
    layer.min_px = layer.min_py = std::numeric_limits<int>::max();
    layer.max_px = layer.max_py = -1;
    for (const std::int64_t cell : decoded.cells) {
      const int x = static_cast<int>(cell % map.size_x), y = static_cast<int>(cell / map.size_x);
      layer.min_px = std::min(layer.min_px, x);
      layer.max_px = std::max(layer.max_px, x);
      layer.min_py = std::min(layer.min_py, y);
      layer.max_py = std::max(layer.max_py, y);
      // Sorted cells run along x: a cell right after the previous one on the same row extends its run.
      if (layer.type != "segment") continue;
      const std::size_t n = layer.runs.size();
      if (n >= 3 && layer.runs[n - 2] == y && layer.runs[n - 3] + layer.runs[n - 1] == x) {
        ++layer.runs[n - 1];
      } else {
        layer.runs.insert(layer.runs.end(), {x, y, 1});
      }
    }
  }
  return decoded;
}

/// Entity points are in cm with y down; ours in metres with y up.
slamcore::Vector2 EntityPoint(double x_cm, double y_cm) { return {x_cm / 100.0, -y_cm / 100.0}; }

Status DecodeEntity(const json& value, std::size_t index, const ValetudoLimits& limits, ValetudoMap& map) {
  const std::string where = "entities[" + std::to_string(index) + "]";
  if (!value.is_object()) return InvalidArgument(where + ": not an object");
  const auto cls = value.find("__class");
  const auto type_it = value.find("type");
  if (cls == value.end() || !cls->is_string())
    return InvalidArgument(where + ".__class: missing or not a string");
  if (type_it == value.end() || !type_it->is_string())
    return InvalidArgument(where + ".type: missing or not a string");
  const std::string kind = cls->get<std::string>(), type = type_it->get<std::string>();
  const auto points_it = value.find("points");
  if (points_it == value.end() || !points_it->is_array())
    return InvalidArgument(where + ".points: missing or not an array");
  const json& raw = *points_it;
  if (raw.size() % 2 != 0) {
    return InvalidArgument(where + ".points: length " + std::to_string(raw.size()) +
                           " is not a multiple of 2");
  }
  if (raw.size() > limits.max_points) {
    return InvalidArgument(where + ".points: " + std::to_string(raw.size()) +
                           " coordinates, more than the limit " + std::to_string(limits.max_points));
  }
  std::vector<slamcore::Vector2> points;
  points.reserve(raw.size() / 2);
  for (std::size_t i = 0; i < raw.size(); i += 2) {
    if (!raw[i].is_number() || !raw[i + 1].is_number()) {
      return InvalidArgument(where + ".points[" + std::to_string(raw[i].is_number() ? i + 1 : i) +
                             "]: not a number");
    }
    const double x = raw[i].get<double>(), y = raw[i + 1].get<double>();
    if (!std::isfinite(x) || !std::isfinite(y) || std::abs(x) > 1e7 || std::abs(y) > 1e7) {
      return InvalidArgument(where + ".points[" + std::to_string(i) + "]: coordinate out of range");
    }
    points.push_back(EntityPoint(x, y));
  }

  if (kind == "PointMapEntity") {
    if (points.size() != 1) {
      return InvalidArgument(where + ".points: a point entity has one point, this has " +
                             std::to_string(points.size()));
    }
    ValetudoPose pose{type, slamcore::SE2(points[0], 0.0), false};
    const auto meta = value.find("metaData");
    if (meta != value.end() && meta->is_object() && meta->contains("angle")) {
      const json& angle = (*meta)["angle"];
      if (!angle.is_number() || !std::isfinite(angle.get<double>())) {
        return InvalidArgument(where + ".metaData.angle: not a number");
      }
      // Degrees, clockwise on screen (y down) = counter-clockwise turned into our y-up frame: negate.
      pose.pose = slamcore::SE2(points[0], -angle.get<double>() * std::numbers::pi / 180.0);
      pose.has_angle = true;
    }
    if (type == "robot_position") {
      map.robot = pose;
    } else if (type == "charger_location") {
      map.dock = pose;
    } else {
      map.other_points.push_back(pose);
    }
  } else if (kind == "PathMapEntity") {
    map.paths.push_back({type, std::move(points)});
  } else if (kind == "LineMapEntity") {
    if (points.size() < 2) return InvalidArgument(where + ".points: a line needs 2 points");
    map.virtual_walls.push_back({type, std::move(points)});
  } else if (kind == "PolygonMapEntity") {
    if (points.size() < 3) return InvalidArgument(where + ".points: a polygon needs at least 3 points");
    map.zones.push_back({type, std::move(points)});
  } else {
    return InvalidArgument(where + ".__class: unknown entity class \"" + kind +
                           "\" (PointMapEntity, PathMapEntity, LineMapEntity or PolygonMapEntity)");
  }
  return Status::Ok();
}

/// Floor and segments free, walls occupied (walls win where layers overlap), cropped with a margin.
slamcore::Result<slamcore::OccupancyGrid> Rasterise(const ValetudoMap& map,
                                                    const std::vector<DecodedLayer>& layers, int margin,
                                                    std::int64_t max_cells) {
  int min_x = std::numeric_limits<int>::max(), min_y = min_x, max_x = -1, max_y = -1;
  for (const DecodedLayer& decoded : layers) {
    if (decoded.layer.pixel_count == 0) continue;
    min_x = std::min(min_x, decoded.layer.min_px);
    max_x = std::max(max_x, decoded.layer.max_px);
    min_y = std::min(min_y, decoded.layer.min_py);
    max_y = std::max(max_y, decoded.layer.max_py);
  }
  if (max_x < 0) return InvalidArgument("layers: no layer covers any pixel; there is no map");
  const std::int64_t width = std::int64_t{max_x} - min_x + 1 + 2 * margin,
                     height = std::int64_t{max_y} - min_y + 1 + 2 * margin;
  if (width * height > max_cells) {
    return InvalidArgument("layers: their pixels span " + std::to_string(max_x - min_x + 1) + " x " +
                           std::to_string(max_y - min_y + 1) + " map pixels, a grid of " +
                           std::to_string(width * height) + " cells with the margin, more than the " +
                           std::to_string(max_cells) + " this import accepts");
  }
  const double resolution = map.pixel_size_cm / 100.0;
  const int left = min_x - margin, bottom = max_y + margin;
  // Pixel (px, py) has its lower-left corner at (px·s, −py·s): the lowest row of the grid is py = bottom.
  ASSIGN_OR_RETURN(auto grid,
                   slamcore::OccupancyGrid::Create(static_cast<int>(width), static_cast<int>(height),
                                                   resolution, left * resolution, -bottom * resolution));
  for (const bool walls : {false, true}) {
    for (const DecodedLayer& decoded : layers) {
      if ((decoded.layer.type == "wall") != walls) continue;
      const auto state =
          static_cast<std::int8_t>(walls ? slamcore::CellState::kOccupied : slamcore::CellState::kFree);
      for (const std::int64_t cell : decoded.cells) {
        const int x = static_cast<int>(cell % map.size_x), y = static_cast<int>(cell / map.size_x);
        grid.at(x - left, bottom - y) = state;
      }
    }
  }
  return grid;
}

}  // namespace

ValetudoLimits ValetudoUploadLimits() {
  ValetudoLimits limits;
  limits.max_inflated_bytes = 32u << 20;
  limits.max_json_values = 4'000'000;
  limits.max_total_pixels = kMaxUploadedMapCells;
  limits.max_grid_cells = kMaxUploadedMapCells;
  return limits;
}

std::int64_t ValetudoMap::AreaOf(std::string_view type) const {
  std::int64_t area = 0;
  for (const ValetudoLayer& layer : layers) {
    if (layer.type == type) area += layer.area_cm2;
  }
  return area;
}

slamcore::Result<ValetudoMap> ParseValetudoMap(std::string_view bytes, const std::string& source,
                                               const ValetudoLimits& limits) {
  if (bytes.size() > limits.max_input_bytes) {
    return InvalidArgument(source + ": " + std::to_string(bytes.size()) + " bytes, more than the limit " +
                           std::to_string(limits.max_input_bytes));
  }
  std::string inflated;
  if (LooksDeflated(bytes)) {
    ASSIGN_OR_RETURN(auto text, Inflate(bytes, source, limits.max_inflated_bytes));
    inflated = std::move(text);
    bytes = inflated;
  }
  JsonShapeCheck shape(limits.max_json_values, limits.max_json_depth);
  (void)json::sax_parse(bytes.begin(), bytes.end(), &shape);
  if (const std::optional<std::string> refusal = shape.Refusal()) {
    return InvalidArgument(source + ": " + *refusal + ", more than a map export may");
  }
  const json root = json::parse(bytes.begin(), bytes.end(), nullptr, /*allow_exceptions=*/false);
  if (root.is_discarded()) return InvalidArgument(source + ": not valid JSON (nor zlib-deflated JSON)");
  if (!root.is_object()) return InvalidArgument(source + ": the top level is not a JSON object");
  const std::string where = source + ": ";
  if (!root.contains("__class") || root["__class"] != "ValetudoMap") {
    return InvalidArgument(where + "__class: not \"ValetudoMap\"");
  }
  ValetudoMap map;
  const auto meta = root.find("metaData");
  if (meta == root.end() || !meta->is_object())
    return InvalidArgument(where + "metaData: missing or not an object");
  auto version = IntField(*meta, "version", "metaData", 0, std::numeric_limits<int>::max());
  if (!version.ok()) return InvalidArgument(where + version.status().message());
  if (*version != 1 && *version != 2) {
    return InvalidArgument(where + "metaData.version: " + std::to_string(*version) +
                           " is not supported (1 or 2)");
  }
  map.version = static_cast<int>(*version);
  map.declared_total_area_cm2 = OptionalInt(*meta, "totalLayerArea");
  for (const json* holder : {&*meta, &root}) {
    const auto stamp = holder->find("timestamp");
    if (stamp == holder->end() || map.timestamp_ms) continue;
    if (stamp->is_number_integer()) {
      const std::int64_t stamp_ms = SaturatedInt(*stamp);
      if (stamp_ms >= 0 && stamp_ms <= kLatestTimeMs) map.timestamp_ms = stamp_ms;
    }
    if (stamp->is_string()) map.timestamp_ms = ParseIsoDateTime(stamp->get<std::string>());
    if (!map.timestamp_ms) {
      return InvalidArgument(where + (holder == &root ? "" : "metaData.") +
                             "timestamp: neither an ISO 8601 date-time nor milliseconds since the epoch");
    }
  }
  auto pixel_size = IntField(root, "pixelSize", "map", 1, 100);
  if (!pixel_size.ok()) return InvalidArgument(where + pixel_size.status().message());
  map.pixel_size_cm = static_cast<int>(*pixel_size);
  const auto size = root.find("size");
  if (size == root.end() || !size->is_object())
    return InvalidArgument(where + "size: missing or not an object");
  auto size_x = IntField(*size, "x", "size", 1, limits.max_map_side);
  if (!size_x.ok()) return InvalidArgument(where + size_x.status().message());
  auto size_y = IntField(*size, "y", "size", 1, limits.max_map_side);
  if (!size_y.ok()) return InvalidArgument(where + size_y.status().message());
  map.size_x = static_cast<int>(*size_x);
  map.size_y = static_cast<int>(*size_y);

  const auto layers = root.find("layers");
  if (layers == root.end() || !layers->is_array())
    return InvalidArgument(where + "layers: missing or not an array");
  if (layers->size() > limits.max_layers) {
    return InvalidArgument(where + "layers: " + std::to_string(layers->size()) +
                           " layers, more than the limit " + std::to_string(limits.max_layers));
  }
  std::vector<DecodedLayer> decoded;
  std::int64_t covered = 0;  // pixels of the layers decoded so far
  for (std::size_t i = 0; i < layers->size(); ++i) {
    auto layer = DecodeLayer((*layers)[i], i, map, PixelBudget::For(limits, covered));
    if (!layer.ok()) return InvalidArgument(where + layer.status().message());
    covered += layer->layer.pixel_count;
    map.layers.push_back(layer->layer);
    decoded.push_back(std::move(layer).value());
  }
  const auto entities = root.find("entities");
  if (entities != root.end()) {
    if (!entities->is_array()) return InvalidArgument(where + "entities: not an array");
    if (entities->size() > limits.max_entities) {
      return InvalidArgument(where + "entities: " + std::to_string(entities->size()) +
                             " entities, more than the limit " + std::to_string(limits.max_entities));
    }
    for (std::size_t i = 0; i < entities->size(); ++i) {
      if (Status status = DecodeEntity((*entities)[i], i, limits, map); !status.ok()) {
        return InvalidArgument(where + status.message());
      }
    }
  }
  auto grid = Rasterise(map, decoded, limits.grid_margin_px, limits.max_grid_cells);
  if (!grid.ok()) return InvalidArgument(where + grid.status().message());
  map.grid = std::move(grid).value();
  return map;
}

slamcore::Result<ValetudoMap> ReadValetudoMap(const std::string& path, const ValetudoLimits& limits) {
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  if (error) return slamcore::NotFound(path + ": " + error.message());
  if (size > limits.max_input_bytes) {
    return InvalidArgument(path + ": " + std::to_string(size) + " bytes, more than the limit " +
                           std::to_string(limits.max_input_bytes));
  }
  ASSIGN_OR_RETURN(auto bytes, slamcore::ReadFileBytes(path));
  return ParseValetudoMap(bytes, path, limits);
}

}  // namespace analyzer
