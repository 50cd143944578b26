// OccupancyGrid basics and ROS map_server PGM + YAML I/O (see occupancy_grid.h).
//
// The YAML reader is a small strict parser for map_server's flat `key: value` files rather than
// cv::FileStorage: FileStorage wants a "%YAML:1.0" header and rejects the plain YAML that map_saver writes.
#include "slamcore/occupancy_grid.h"

#include "slamcore/graph_io.h"

#include "grid_pixels.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace slamcore {
namespace {

constexpr std::uint8_t kFreePixel = 254, kOccupiedPixel = 0, kUnknownPixel = 205;

Status CheckSize(std::int64_t width, std::int64_t height, const std::string& what) {
  if (width <= 0 || height <= 0) {
    return InvalidArgument(what + ": empty map (" + std::to_string(width) + " x " + std::to_string(height) +
                           ")");
  }
  if (width > kMaxGridSide || height > kMaxGridSide) {
    return InvalidArgument(what + ": map of " + std::to_string(width) + " x " + std::to_string(height) +
                           " cells is wider or taller than the " + std::to_string(kMaxGridSide) +
                           " cells a side a map may have");
  }
  if (width * height > kMaxGridCells) {
    return InvalidArgument(what + ": map of " + std::to_string(width) + " x " + std::to_string(height) +
                           " = " + std::to_string(width * height) + " cells, more than the " +
                           std::to_string(kMaxGridCells) + " a map may have");
  }
  return Status::Ok();
}

std::string Trim(std::string_view text) {
  const auto begin = text.find_first_not_of(" \t\r");
  if (begin == std::string_view::npos) return {};
  const auto end = text.find_last_not_of(" \t\r");
  return std::string(text.substr(begin, end - begin + 1));
}

bool ParseDouble(const std::string& text, double* value) {
  const std::string trimmed = Trim(text);
  if (trimmed.empty()) return false;
  const char* end = trimmed.data() + trimmed.size();
  const auto [ptr, error] = std::from_chars(trimmed.data(), end, *value);
  return error == std::errc() && ptr == end && std::isfinite(*value);
}

std::string Unquote(std::string text) {
  if (text.size() >= 2 && (text.front() == '"' || text.front() == '\'') && text.back() == text.front()) {
    return text.substr(1, text.size() - 2);
  }
  return text;
}

/// Reads the next PGM header token, skipping whitespace and '#' comments.
bool NextPgmToken(const std::string& bytes, std::size_t* pos, std::string* token) {
  while (*pos < bytes.size()) {
    const char c = bytes[*pos];
    if (c == '#') {
      while (*pos < bytes.size() && bytes[*pos] != '\n') ++*pos;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      ++*pos;
    } else {
      break;
    }
  }
  token->clear();
  while (*pos < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[*pos])) &&
         bytes[*pos] != '#') {
    token->push_back(bytes[(*pos)++]);
    if (token->size() > 32) return false;
  }
  return !token->empty();
}

bool ParseInt(const std::string& text, std::int64_t* value) {
  const char* end = text.data() + text.size();
  const auto [ptr, error] = std::from_chars(text.data(), end, *value);
  return error == std::errc() && ptr == end;
}

}  // namespace

Result<OccupancyGrid> OccupancyGrid::Create(int width, int height, double resolution, double origin_x,
                                            double origin_y) {
  RETURN_IF_ERROR(CheckSize(width, height, "OccupancyGrid::Create"));
  if (!(resolution > 0.0) || !std::isfinite(resolution) || resolution > 100.0) {
    return InvalidArgument("OccupancyGrid::Create: resolution must be in (0, 100] m, got " +
                           std::to_string(resolution));
  }
  if (!std::isfinite(origin_x) || !std::isfinite(origin_y)) {
    return InvalidArgument("OccupancyGrid::Create: origin is not finite");
  }
  OccupancyGrid grid;
  grid.resolution = resolution;
  grid.origin_x = origin_x;
  grid.origin_y = origin_y;
  grid.width = width;
  grid.height = height;
  grid.cells.assign(static_cast<std::size_t>(width) * height, static_cast<std::int8_t>(CellState::kUnknown));
  return grid;
}

std::int64_t OccupancyGrid::CountCells(CellState state) const {
  return std::count(cells.begin(), cells.end(), static_cast<std::int8_t>(state));
}

std::int8_t CellFromPixel(int pixel, double occupied_thresh, double free_thresh, bool negate) {
  // map_server: p = (255 − v) / 255 is the occupancy probability (v / 255 when negated).
  const double p = negate ? pixel / 255.0 : (255.0 - pixel) / 255.0;
  if (p > occupied_thresh) return static_cast<std::int8_t>(CellState::kOccupied);
  if (p < free_thresh) return static_cast<std::int8_t>(CellState::kFree);
  return static_cast<std::int8_t>(CellState::kUnknown);
}

std::uint8_t PixelFromCell(std::int8_t cell) {
  if (cell == static_cast<std::int8_t>(CellState::kFree)) return kFreePixel;
  if (cell == static_cast<std::int8_t>(CellState::kOccupied)) return kOccupiedPixel;
  return kUnknownPixel;
}

Status CheckThresholds(double occupied_thresh, double free_thresh, double resolution) {
  if (!(resolution > 0.0) || resolution > 100.0 || !std::isfinite(resolution)) {
    return InvalidArgument("resolution must be in (0, 100] m/cell, got " + std::to_string(resolution));
  }
  if (!(free_thresh >= 0.0 && free_thresh <= occupied_thresh && occupied_thresh <= 1.0)) {
    return InvalidArgument("thresholds must satisfy 0 <= free_thresh <= occupied_thresh <= 1");
  }
  return Status::Ok();
}

Result<OccupancyGrid> DecodePgm(const std::string& bytes, double resolution, double origin_x, double origin_y,
                                double occupied_thresh, double free_thresh, bool negate) {
  RETURN_IF_ERROR(CheckThresholds(occupied_thresh, free_thresh, resolution));
  std::size_t pos = 0;
  std::string magic, token;
  if (!NextPgmToken(bytes, &pos, &magic) || (magic != "P5" && magic != "P2")) {
    return DataLoss("PGM: not a greyscale PGM (magic must be P5 or P2)");
  }
  std::int64_t values[3] = {0, 0, 0};
  const char* names[3] = {"width", "height", "maxval"};
  for (int i = 0; i < 3; ++i) {
    if (!NextPgmToken(bytes, &pos, &token) || !ParseInt(token, &values[i])) {
      return DataLoss(std::string("PGM: header field ") + names[i] + " missing or not a number");
    }
  }
  RETURN_IF_ERROR(CheckSize(values[0], values[1], "PGM"));
  if (values[2] <= 0 || values[2] > 255) {
    return DataLoss("PGM: maxval " + std::to_string(values[2]) + " unsupported (8-bit maps only, 1..255)");
  }
  const std::int64_t count = values[0] * values[1];
  // A header that promises more pixels than the bytes can hold is refused before the grid is allocated.
  const std::int64_t available = static_cast<std::int64_t>(bytes.size() - std::min(pos, bytes.size()));
  if ((magic == "P5" && available - 1 < count) || (magic == "P2" && available < 2 * count - 1)) {
    return DataLoss("PGM: truncated pixel data (" + std::to_string(std::max<std::int64_t>(available - 1, 0)) +
                    " bytes for " + std::to_string(count) + " pixels)");
  }
  ASSIGN_OR_RETURN(auto grid, OccupancyGrid::Create(static_cast<int>(values[0]), static_cast<int>(values[1]),
                                                    resolution, origin_x, origin_y));
  const double scale = 255.0 / static_cast<double>(values[2]);
  auto store = [&](std::int64_t index, int pixel) {
    const int col = static_cast<int>(index % values[0]);
    const int image_row = static_cast<int>(index / values[0]);
    grid.at(col, grid.ImageRowOf(image_row)) =
        CellFromPixel(static_cast<int>(std::lround(pixel * scale)), occupied_thresh, free_thresh, negate);
  };
  if (magic == "P5") {
    ++pos;  // exactly one whitespace byte after maxval
    if (pos > bytes.size() || static_cast<std::int64_t>(bytes.size() - pos) < count) {
      return DataLoss("PGM: truncated pixel data (" +
                      std::to_string(bytes.size() - std::min(pos, bytes.size())) + " bytes for " +
                      std::to_string(count) + " pixels)");
    }
    for (std::int64_t i = 0; i < count; ++i) {
      const int pixel = static_cast<unsigned char>(bytes[pos + static_cast<std::size_t>(i)]);
      if (pixel > values[2]) return DataLoss("PGM: pixel " + std::to_string(i) + " exceeds maxval");
      store(i, pixel);
    }
  } else {
    for (std::int64_t i = 0; i < count; ++i) {
      std::int64_t pixel = 0;
      if (!NextPgmToken(bytes, &pos, &token) || !ParseInt(token, &pixel) || pixel < 0 || pixel > values[2]) {
        return DataLoss("PGM: ASCII pixel " + std::to_string(i) + " missing or out of range");
      }
      store(i, static_cast<int>(pixel));
    }
  }
  return grid;
}

std::string EncodePgm(const OccupancyGrid& grid) {
  std::string header = "P5\n# slamcore occupancy grid " + std::to_string(grid.resolution) + " m/pix\n" +
                       std::to_string(grid.width) + " " + std::to_string(grid.height) + "\n255\n";
  std::string bytes = header;
  bytes.reserve(header.size() + grid.cells.size());
  for (int image_row = 0; image_row < grid.height; ++image_row) {
    const int row = grid.ImageRowOf(image_row);
    for (int col = 0; col < grid.width; ++col)
      bytes.push_back(static_cast<char>(PixelFromCell(grid.at(col, row))));
  }
  return bytes;
}

Result<std::string> ReadFileBytes(const std::string& path, std::uintmax_t max_bytes) {
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  if (error) return NotFound(path + ": cannot read (" + error.message() + ")");
  if (size > max_bytes) {
    return InvalidArgument(path + ": " + std::to_string(size) + " bytes, more than the " +
                           std::to_string(max_bytes) + " it may have");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return NotFound(path + ": cannot open");
  std::string bytes(static_cast<std::size_t>(size), '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(size));
  if (!in) return DataLoss(path + ": short read");
  return bytes;
}

Status WriteFileBytes(const std::string& path, const std::string& bytes) {
  return WriteFileReplacing(path, [&](std::ostream& output) {
    output.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  });
}

Result<OccupancyGrid> ReadMapServerYaml(const std::string& yaml_path) {
  ASSIGN_OR_RETURN(auto text, ReadFileBytes(yaml_path));
  return ParseMapServerYaml(text, yaml_path, [&](const std::string& name) -> Result<std::string> {
    std::filesystem::path image = name;
    if (image.is_relative()) image = std::filesystem::path(yaml_path).parent_path() / image;
    ASSIGN_OR_RETURN(auto bytes, ReadFileBytes(image.string()));
    return bytes;
  });
}

Result<OccupancyGrid> ParseMapServerYaml(
    const std::string& yaml_text, const std::string& source,
    const std::function<Result<std::string>(const std::string& image)>& read_image) {
  const std::string& yaml_path = source;
  if (yaml_text.size() > 65536) return InvalidArgument(yaml_path + ": too large for a map_server YAML file");
  std::map<std::string, std::string> keys;
  std::istringstream lines(yaml_text);
  std::string line;
  int line_number = 0;
  while (std::getline(lines, line)) {
    ++line_number;
    const auto hash = line.find('#');
    if (hash != std::string::npos && line.find_first_of("'\"") > hash) line.resize(hash);
    if (Trim(line).empty() || Trim(line) == "---") continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) {
      return DataLoss(yaml_path + ":" + std::to_string(line_number) + ": expected 'key: value'");
    }
    keys[Trim(std::string_view(line).substr(0, colon))] = Trim(std::string_view(line).substr(colon + 1));
  }
  auto fail = [&](const std::string& what) { return DataLoss(yaml_path + ": " + what); };
  for (const char* required : {"image", "resolution", "origin"}) {
    if (!keys.contains(required)) return fail(std::string("missing key '") + required + "'");
  }
  double resolution = 0.0, occupied_thresh = 0.65, free_thresh = 0.196, negate = 0.0;
  if (!ParseDouble(keys["resolution"], &resolution)) return fail("resolution is not a number");
  if (keys.contains("occupied_thresh") && !ParseDouble(keys["occupied_thresh"], &occupied_thresh)) {
    return fail("occupied_thresh is not a number");
  }
  if (keys.contains("free_thresh") && !ParseDouble(keys["free_thresh"], &free_thresh)) {
    return fail("free_thresh is not a number");
  }
  if (keys.contains("negate") && !ParseDouble(keys["negate"], &negate)) return fail("negate is not 0 or 1");
  if (keys.contains("mode") && keys["mode"] != "trinary" && keys["mode"] != "scale") {
    return fail("mode '" + keys["mode"] + "' unsupported (trinary or scale)");
  }
  std::string origin = keys["origin"];
  if (origin.size() < 2 || origin.front() != '[' || origin.back() != ']')
    return fail("origin must be [x, y, yaw]");
  origin = origin.substr(1, origin.size() - 2);
  double origin_values[3];
  std::istringstream parts(origin);
  std::string part;
  int count = 0;
  while (std::getline(parts, part, ',')) {
    if (count >= 3 || !ParseDouble(part, &origin_values[count]))
      return fail("origin must be [x, y, yaw] numbers");
    ++count;
  }
  if (count != 3) return fail("origin must have 3 numbers");
  if (Status status = CheckThresholds(occupied_thresh, free_thresh, resolution); !status.ok()) {
    return fail(status.message());
  }
  const std::string image = Unquote(keys["image"]);
  if (image.empty()) return fail("image is empty");
  ASSIGN_OR_RETURN(auto bytes, read_image(image));
  const bool is_png = bytes.size() >= 8 && bytes.compare(0, 4, "\x89PNG") == 0;
  auto grid = is_png ? DecodePng(bytes, resolution, origin_values[0], origin_values[1], occupied_thresh,
                                 free_thresh, negate != 0.0)
                     : DecodePgm(bytes, resolution, origin_values[0], origin_values[1], occupied_thresh,
                                 free_thresh, negate != 0.0);
  if (!grid.ok())
    return Status(grid.status().code(), yaml_path + ": image " + image + ": " + grid.status().message());
  grid->origin_yaw = origin_values[2];
  return grid;
}

Status WriteMapServerYaml(const OccupancyGrid& grid, const std::string& yaml_path, bool png) {
  RETURN_IF_ERROR(CheckSize(grid.width, grid.height, yaml_path));
  if (grid.cells.size() != static_cast<std::size_t>(grid.width) * grid.height) {
    return InvalidArgument(yaml_path + ": grid cells do not match width x height");
  }
  std::filesystem::path image = std::filesystem::path(yaml_path).replace_extension(png ? ".png" : ".pgm");
  if (image == std::filesystem::path(yaml_path)) {
    return InvalidArgument(yaml_path + ": names the map's image; the YAML needs its own name (e.g. " +
                           std::filesystem::path(yaml_path).replace_extension(".yaml").string() +
                           "), and the image is written beside it");
  }
  std::string bytes;
  if (png) {
    ASSIGN_OR_RETURN(auto encoded, EncodePng(grid));
    bytes = std::move(encoded);
  } else {
    bytes = EncodePgm(grid);
  }
  RETURN_IF_ERROR(WriteFileBytes(image.string(), bytes));
  return WriteFileBytes(yaml_path, MapServerYaml(grid, image.filename().string()));
}

std::string MapServerYaml(const OccupancyGrid& grid, const std::string& image_file) {
  // The shortest text that reads back as the same double: a resolution of 1e-7 or an origin of 1e300 is
  // written as it is (fixed decimals wrote "0.000000", and a long origin was cut off by a fixed buffer).
  const auto number = [](double value) {
    char text[32];
    const auto end = std::to_chars(text, text + sizeof text, value).ptr;
    return std::string(text, end);
  };
  return "image: " + image_file + "\nresolution: " + number(grid.resolution) + "\norigin: [" +
         number(grid.origin_x) + ", " + number(grid.origin_y) + ", " + number(grid.origin_yaw) +
         "]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
}

}  // namespace slamcore
