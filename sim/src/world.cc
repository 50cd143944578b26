#include "sim/world.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

#include "slamcore/occupancy_grid.h"

namespace sim {

Grid::Grid(int width, int height, double resolution, Vector2 origin, Cell fill)
    : width_(width),
      height_(height),
      resolution_(resolution),
      origin_(std::move(origin)),
      cells_(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), fill) {}

std::pair<int, int> Grid::CellOf(const Vector2& point) const {
  const Vector2 local = (point - origin_) / resolution_;
  return {static_cast<int>(std::floor(local.x())), static_cast<int>(std::floor(local.y()))};
}

Vector2 Grid::CentreOf(int i, int j) const { return origin_ + Vector2(i + 0.5, j + 0.5) * resolution_; }

Cell Grid::AtPoint(const Vector2& point) const {
  const auto [i, j] = CellOf(point);
  return at(i, j);
}

bool Grid::DiscIsFree(const Vector2& point, double radius) const {
  const int reach = static_cast<int>(std::ceil(radius / resolution_));
  const auto [ci, cj] = CellOf(point);
  for (int dj = -reach; dj <= reach; ++dj) {
    for (int di = -reach; di <= reach; ++di) {
      if ((CentreOf(ci + di, cj + dj) - point).norm() > radius) continue;
      if (at(ci + di, cj + dj) != Cell::kFree) return false;
    }
  }
  return true;
}

double Grid::CastRay(const Vector2& from, double angle, double max_range) const {
  const Vector2 direction(std::cos(angle), std::sin(angle));
  const double step = 0.5 * resolution_;
  for (double distance = 0.0; distance < max_range; distance += step) {
    if (AtPoint(from + distance * direction) != Cell::kFree) return distance;
  }
  return max_range;
}

bool Grid::LineOfSight(const Vector2& from, const Vector2& to) const {
  const Vector2 delta = to - from;
  const double length = delta.norm();
  const int steps = static_cast<int>(std::ceil(length / (0.5 * resolution_)));
  for (int k = 1; k < steps; ++k) {
    if (AtPoint(from + delta * (static_cast<double>(k) / steps)) == Cell::kOccupied) return false;
  }
  return true;
}

bool FloorFeature::Contains(const Vector2& point) const {
  const Vector2 local = pose.inverse() * point;
  return std::abs(local.x()) <= half_size.x() && std::abs(local.y()) <= half_size.y();
}

const FloorFeature* World::FeatureAt(const Vector2& point) const {
  for (const std::vector<FloorFeature>* features : {&low_furniture, &rugs}) {
    for (const FloorFeature& feature : *features) {
      if (feature.Contains(point)) return &feature;
    }
  }
  return nullptr;
}

Surface World::SurfaceAt(const Vector2& point) const {
  const FloorFeature* feature = FeatureAt(point);
  if (feature == nullptr) return Surface::kFloor;
  return feature->kind == "rug" ? Surface::kRug : Surface::kUnderFurniture;
}

slamcore::Result<HomeClutter> ParseHomeClutter(const std::string& name) {
  if (name == "typical") return HomeClutter::kTypical;
  if (name == "high") return HomeClutter::kHigh;
  return slamcore::InvalidArgument("home clutter '" + name + "': expected 'typical' or 'high'");
}

const char* HomeClutterName(HomeClutter clutter) {
  return clutter == HomeClutter::kHigh ? "high" : "typical";
}

void PlaceFloorFeatures(World& world, HomeClutter clutter, std::mt19937_64& random) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double low, double high) { return low + (high - low) * unit(random); };
  // A rectangle centred within 1.5 m of the room's seed, at a right angle to the map or turned at random,
  // placed where every cell under it is free floor not yet covered; 30 tries.
  const bool high = clutter == HomeClutter::kHigh;
  auto place = [&](const Room& room, const char* kind, double min_x, double max_x, double min_y, double max_y,
                   std::vector<FloorFeature>& into) {
    const bool rug = std::string(kind) == "rug";
    const double catch_probability = rug ? (high ? 0.05 : 1.0 / 700) : (high ? 0.15 : 1.0 / 250);
    for (int attempt = 0; attempt < 30; ++attempt) {
      FloorFeature feature{kind,
                           SE2(room.seed + Vector2(uniform(-1.5, 1.5), uniform(-1.5, 1.5)),
                               unit(random) < 0.7 ? 0.5 * std::numbers::pi * std::floor(uniform(0.0, 4.0))
                                                  : uniform(-std::numbers::pi, std::numbers::pi)),
                           0.5 * Vector2(uniform(min_x, max_x), uniform(min_y, max_y)), catch_probability};
      bool fits = true;
      const double step = world.grid.resolution();
      for (double x = -feature.half_size.x(); fits && x <= feature.half_size.x(); x += step) {
        for (double y = -feature.half_size.y(); fits && y <= feature.half_size.y(); y += step) {
          const Vector2 point = feature.pose * Vector2(x, y);
          fits = world.grid.AtPoint(point) == Cell::kFree && world.SurfaceAt(point) == Surface::kFloor;
        }
      }
      if (!fits) continue;
      into.push_back(feature);
      return;
    }
  };
  for (const Room& room : world.rooms) {
    const bool living = room.label == "living_room" || room.label == "room";
    const bool bedroom = room.label == "bedroom";
    const bool no_rugs = room.label == "bathroom" || room.label == "restroom" ||
                         room.label == "washing_room" || room.label == "kitchen" ||
                         room.label == "corridor" || room.label == "balcony";
    // Low furniture first: it needs the most floor.
    if (bedroom && (high || unit(random) < 0.3)) place(room, "bed", 1.4, 1.8, 1.9, 2.1, world.low_furniture);
    if (living && (high || unit(random) < 0.3)) place(room, "sofa", 0.8, 1.0, 1.6, 2.2, world.low_furniture);
    const int rugs = high ? (living || bedroom ? 2 : 1)
                          : (no_rugs ? 0 : (unit(random) < (living || bedroom ? 0.5 : 0.2) ? 1 : 0));
    for (int k = 0; k < rugs; ++k) place(room, "rug", 0.8, 2.5, 0.6, 1.8, world.rugs);
  }
}

std::vector<Vector2> World::FreeSpots(double radius, std::size_t max_count, std::mt19937_64& random) const {
  std::vector<Vector2> spots;
  for (int j = 0; j < grid.height(); j += 3) {
    for (int i = 0; i < grid.width(); i += 3) {
      const Vector2 centre = grid.CentreOf(i, j);
      if (grid.at(i, j) == Cell::kFree && grid.DiscIsFree(centre, radius)) spots.push_back(centre);
    }
  }
  std::shuffle(spots.begin(), spots.end(), random);
  if (spots.size() > max_count) spots.resize(max_count);
  return spots;
}

namespace {

constexpr double kResolution = 0.05;  // metres per cell of the simulated world
constexpr double kWallThickness = 0.12;

struct Segment {
  Vector2 a, b;
};

void Rasterise(Grid& grid, const Segment& segment, double thickness, Cell cell) {
  const Vector2 delta = segment.b - segment.a;
  const double length = delta.norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(length / (0.25 * grid.resolution()))));
  const int reach = static_cast<int>(std::ceil(0.5 * thickness / grid.resolution()));
  for (int k = 0; k <= steps; ++k) {
    const Vector2 point = segment.a + delta * (static_cast<double>(k) / steps);
    const auto [ci, cj] = grid.CellOf(point);
    for (int dj = -reach; dj <= reach; ++dj) {
      for (int di = -reach; di <= reach; ++di) {
        if ((grid.CentreOf(ci + di, cj + dj) - point).norm() <= 0.5 * thickness + 0.5 * grid.resolution()) {
          grid.set(ci + di, cj + dj, cell);
        }
      }
    }
  }
}

/// Marks every unknown cell 4-connected to `seed` as free, stopping at walls and fixtures.
void FloodFree(Grid& grid, const Vector2& seed) {
  const auto [si, sj] = grid.CellOf(seed);
  if (grid.at(si, sj) != Cell::kUnknown) return;
  std::deque<std::pair<int, int>> queue{{si, sj}};
  grid.set(si, sj, Cell::kFree);
  while (!queue.empty()) {
    const auto [i, j] = queue.front();
    queue.pop_front();
    for (const auto& [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      if (grid.at(i + di, j + dj) == Cell::kUnknown && grid.Contains(i + di, j + dj)) {
        grid.set(i + di, j + dj, Cell::kFree);
        queue.emplace_back(i + di, j + dj);
      }
    }
  }
}

/// Direction from `point` towards the most open side, for orienting landmarks into the room.
double OpenDirection(const Grid& grid, const Vector2& point) {
  double best_angle = 0.0, best_range = -1.0;
  for (int k = 0; k < 16; ++k) {
    const double angle = k * std::numbers::pi / 8;
    const double range = grid.CastRay(point, angle, 3.0);
    if (range > best_range) {
      best_range = range;
      best_angle = angle;
    }
  }
  return best_angle;
}

/// Kinds of placed furniture: symmetric ones produce flipped observations from the opposite side.
struct FurnitureKind {
  const char* kind;
  bool symmetric;
};

void PlaceLandmarks(World& world, const std::vector<std::pair<std::string, Vector2>>& fixtures,
                    std::mt19937_64& random) {
  std::map<std::string, int> appearance_of_kind;  // look-alikes share an appearance
  int next_appearance = 1;
  auto appearance_for = [&](const std::string& kind, bool unique) {
    if (unique) return next_appearance++;
    auto [it, inserted] = appearance_of_kind.emplace(kind, next_appearance);
    if (inserted) ++next_appearance;
    return it->second;
  };
  auto add = [&](const std::string& kind, const SE2& pose, bool symmetric, bool unique, int room) {
    Landmark landmark;
    landmark.id = static_cast<int>(world.landmarks.size());
    landmark.appearance = appearance_for(kind, unique);
    landmark.pose = pose;
    landmark.symmetric = symmetric;
    landmark.kind = kind;
    landmark.room = room;
    world.landmarks.push_back(landmark);
  };
  auto nearest_room = [&](const Vector2& point) {
    int best = -1;
    double best_distance = 1e18;
    for (std::size_t r = 0; r < world.rooms.size(); ++r) {
      const double distance = (world.rooms[r].seed - point).norm();
      if (distance < best_distance && world.grid.LineOfSight(point, world.rooms[r].seed)) {
        best_distance = distance;
        best = static_cast<int>(r);
      }
    }
    return best;
  };

  // Fixtures from the floor plan: look-alikes (every washing basin looks the same).
  for (const auto& [kind, centre] : fixtures) {
    add(kind, SE2(centre, OpenDirection(world.grid, centre)), false, false, nearest_room(centre));
  }
  // Per room: a ceiling lamp over its seed (symmetric), and by label a bed or a table (symmetric), or a
  // chair (a look-alike shared by all rooms).
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
  std::uniform_real_distribution<double> offset(-0.8, 0.8);
  for (std::size_t r = 0; r < world.rooms.size(); ++r) {
    const Room& room = world.rooms[r];
    add("ceiling_lamp", SE2(room.seed, angle(random)), true, false, static_cast<int>(r));
    const bool sleeping = room.label == "bedroom";
    const bool dining = room.label == "living_room" || room.label == "kitchen" || room.label == "room";
    for (int attempt = 0; attempt < 10 && (sleeping || dining); ++attempt) {
      const Vector2 spot = room.seed + Vector2(offset(random), offset(random));
      if (world.grid.AtPoint(spot) != Cell::kFree) continue;
      add(sleeping ? "bed" : "table", SE2(spot, angle(random)), true, true, static_cast<int>(r));
      break;
    }
    if (!sleeping && !dining) {
      const Vector2 spot = room.seed + Vector2(offset(random), offset(random));
      if (world.grid.AtPoint(spot) == Cell::kFree)
        add("chair", SE2(spot, angle(random)), false, false, static_cast<int>(r));
    }
  }
  // Pictures on walls, facing into the room: unique textures, the bulk of the views.
  std::vector<Vector2> wall_spots;
  for (int j = 1; j + 1 < world.grid.height(); ++j) {
    for (int i = 1; i + 1 < world.grid.width(); ++i) {
      if (world.grid.at(i, j) != Cell::kFree) continue;
      const bool by_wall =
          world.grid.at(i + 1, j) == Cell::kOccupied || world.grid.at(i - 1, j) == Cell::kOccupied ||
          world.grid.at(i, j + 1) == Cell::kOccupied || world.grid.at(i, j - 1) == Cell::kOccupied;
      if (by_wall) wall_spots.push_back(world.grid.CentreOf(i, j));
    }
  }
  std::shuffle(wall_spots.begin(), wall_spots.end(), random);
  // About one picture per 1.5 m of wall (wall_spots counts cells along walls on both sides).
  const std::size_t pictures = std::max<std::size_t>(
      4, static_cast<std::size_t>(static_cast<double>(wall_spots.size()) * world.grid.resolution() / 1.5));
  std::vector<Vector2> placed;
  for (const Vector2& spot : wall_spots) {
    if (placed.size() >= pictures) break;
    if (std::any_of(placed.begin(), placed.end(),
                    [&](const Vector2& other) { return (other - spot).norm() < 0.8; })) {
      continue;
    }
    placed.push_back(spot);
    add("picture", SE2(spot, OpenDirection(world.grid, spot)), false, true, nearest_room(spot));
  }
}

SE2 PlaceDock(const World& world, std::mt19937_64& random) {
  // A free spot next to a wall, facing the most open direction.
  auto spots = world.FreeSpots(0.25, 2000, random);
  for (const Vector2& spot : spots) {
    double nearest_wall = 1e9;
    for (int k = 0; k < 8; ++k)
      nearest_wall = std::min(nearest_wall, world.grid.CastRay(spot, k * std::numbers::pi / 4, 1.0));
    if (nearest_wall < 0.45) return SE2(spot, OpenDirection(world.grid, spot));
  }
  return spots.empty() ? SE2() : SE2(spots.front(), 0.0);
}

slamcore::Result<World> LoadFloorPlan(const std::filesystem::path& path, std::uint64_t seed,
                                      HomeClutter clutter) {
  std::ifstream input(path);
  if (!input) return slamcore::NotFound(path.string() + ": cannot open file");
  std::vector<Segment> walls, doors;
  std::vector<std::pair<std::string, std::pair<Vector2, Vector2>>> boxes;  // rooms and fixtures
  std::string line;
  int line_number = 0;
  double min_x = 1e18, min_y = 1e18, max_x = -1e18, max_y = -1e18;
  while (std::getline(input, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream fields(line);
    double x0, y0, x1, y1;
    std::string category;
    if (!(fields >> x0 >> y0 >> x1 >> y1 >> category) || !std::isfinite(x0 + y0 + x1 + y1)) {
      return slamcore::InvalidArgument(path.string() + ":" + std::to_string(line_number) +
                                       ": expected 'x_min y_min x_max y_max category'");
    }
    // Image y grows downwards; the world's y grows upwards.
    const Vector2 a(x0 * kFloorPlanMetresPerPixel, -y0 * kFloorPlanMetresPerPixel);
    const Vector2 b(x1 * kFloorPlanMetresPerPixel, -y1 * kFloorPlanMetresPerPixel);
    min_x = std::min({min_x, a.x(), b.x()});
    max_x = std::max({max_x, a.x(), b.x()});
    min_y = std::min({min_y, a.y(), b.y()});
    max_y = std::max({max_y, a.y(), b.y()});
    if (category == "wall") {
      walls.push_back({a, b});
    } else if (category == "door") {
      doors.push_back({a, b});
    } else {
      boxes.emplace_back(category, std::pair{a.cwiseMin(b), a.cwiseMax(b)});
    }
  }
  if (walls.size() < 3)
    return slamcore::InvalidArgument(path.string() + ": fewer than 3 walls: not a floor plan");
  const double extent = std::max(max_x - min_x, max_y - min_y);
  if (extent > 200.0) return slamcore::InvalidArgument(path.string() + ": larger than 200 m: not a home");

  World world;
  world.name = path.stem().string();
  const double margin = 0.5;
  const int width = static_cast<int>(std::ceil((max_x - min_x + 2 * margin) / kResolution));
  const int height = static_cast<int>(std::ceil((max_y - min_y + 2 * margin) / kResolution));
  world.grid = Grid(width, height, kResolution, Vector2(min_x - margin, min_y - margin), Cell::kUnknown);
  for (const Segment& wall : walls) Rasterise(world.grid, wall, kWallThickness, Cell::kOccupied);
  for (const Segment& door : doors)
    Rasterise(world.grid, door, kWallThickness + 2 * kResolution, Cell::kUnknown);

  static const std::set<std::string> kRoomLabels = {"bedroom",  "kitchen",  "living_room",  "bathroom",
                                                    "corridor", "restroom", "washing_room", "entrance",
                                                    "balcony",  "room"};
  std::vector<std::pair<std::string, Vector2>> fixtures;
  for (const auto& [category, box] : boxes) {
    const Vector2 centre = 0.5 * (box.first + box.second);
    if (kRoomLabels.contains(category)) {
      world.rooms.push_back({category, centre});
    } else if (category != "special" && category != "PS" && category != "point" && category != "stairs") {
      // Fixtures (toilet, bathtub, washing basin, cooking counter, closet) block the robot.
      for (double x = box.first.x(); x <= box.second.x(); x += 0.5 * kResolution) {
        Rasterise(world.grid, {Vector2(x, box.first.y()), Vector2(x, box.second.y())}, kResolution,
                  Cell::kOccupied);
      }
      fixtures.emplace_back(category, centre);
    }
  }
  // Rooms are the free space reachable from their labels; doors join them.
  for (const Room& room : world.rooms) FloodFree(world.grid, room.seed);
  // Balconies are outside; robots stay in: everything still unknown stays unknown.
  std::erase_if(world.rooms, [&](const Room& room) { return world.grid.AtPoint(room.seed) != Cell::kFree; });
  if (world.rooms.empty())
    return slamcore::InvalidArgument(path.string() + ": no room label lies inside the walls");
  // Fixture landmarks sit in front of the fixture, on the free side.
  for (auto& [kind, centre] : fixtures) {
    const double direction = OpenDirection(world.grid, centre);
    for (double step = 0.0; step < 1.0 && world.grid.AtPoint(centre) != Cell::kFree; step += kResolution) {
      centre += kResolution * Vector2(std::cos(direction), std::sin(direction));
    }
  }
  std::mt19937_64 random(seed);
  PlaceLandmarks(world, fixtures, random);
  world.dock = PlaceDock(world, random);
  PlaceFloorFeatures(world, clutter, random);
  return world;
}

slamcore::Result<World> LoadOccupancyMap(const std::filesystem::path& path, std::uint64_t seed,
                                         HomeClutter clutter) {
  ASSIGN_OR_RETURN(const auto map, slamcore::ReadMapServerYaml(path.string()));
  const slamcore::OccupancyGrid& source = map;
  World world;
  world.name = path.stem().string();
  world.grid = Grid(source.width, source.height, source.resolution, Vector2(source.origin_x, source.origin_y),
                    Cell::kUnknown);
  for (int row = 0; row < source.height; ++row) {
    for (int col = 0; col < source.width; ++col) {
      const auto value = static_cast<slamcore::CellState>(source.at(col, row));
      world.grid.set(col, row,
                     value == slamcore::CellState::kFree       ? Cell::kFree
                     : value == slamcore::CellState::kOccupied ? Cell::kOccupied
                                                               : Cell::kUnknown);
    }
  }
  // Rooms: well-separated free spots, farthest-point sampled (maps carry no room labels).
  std::mt19937_64 random(seed);
  const std::vector<Vector2> spots = world.FreeSpots(0.3, 5000, random);
  if (spots.empty()) return slamcore::InvalidArgument(path.string() + ": no free space a robot fits in");
  std::vector<Vector2> seeds{spots.front()};
  const double area =
      static_cast<double>(spots.size()) * 9 * world.grid.resolution() * world.grid.resolution();
  const std::size_t room_count = std::clamp<std::size_t>(static_cast<std::size_t>(area / 12.0), 2, 10);
  while (seeds.size() < room_count) {
    const auto farthest =
        std::max_element(spots.begin(), spots.end(), [&](const Vector2& a, const Vector2& b) {
          auto nearest = [&](const Vector2& p) {
            double d = 1e18;
            for (const Vector2& s : seeds) d = std::min(d, (s - p).norm());
            return d;
          };
          return nearest(a) < nearest(b);
        });
    seeds.push_back(*farthest);
  }
  for (std::size_t r = 0; r < seeds.size(); ++r)
    world.rooms.push_back({r == 0 ? "living_room" : (r % 3 == 1 ? "bedroom" : "room"), seeds[r]});
  PlaceLandmarks(world, {}, random);
  world.dock = PlaceDock(world, random);
  PlaceFloorFeatures(world, clutter, random);
  return world;
}

}  // namespace

slamcore::Result<World> LoadWorld(const std::filesystem::path& path, std::uint64_t seed,
                                  HomeClutter clutter) {
  const std::string extension = path.extension().string();
  if (extension == ".txt") return LoadFloorPlan(path, seed, clutter);
  if (extension == ".yaml" || extension == ".yml") return LoadOccupancyMap(path, seed, clutter);
  return slamcore::InvalidArgument(path.string() +
                                   ": not a home file (expected a floor plan .txt or a map_server .yaml)");
}

slamcore::Result<std::vector<std::filesystem::path>> ListWorlds(const std::filesystem::path& directory) {
  std::error_code error;
  if (!std::filesystem::is_directory(directory, error)) {
    return slamcore::NotFound(directory.string() + ": not a directory");
  }
  std::vector<std::filesystem::path> worlds;
  for (const auto& entry : std::filesystem::directory_iterator(directory)) {
    const std::string extension = entry.path().extension().string();
    const std::string name = entry.path().filename().string();
    if (name == "SOURCES.md") continue;
    if (extension == ".txt" || extension == ".yaml" || extension == ".yml") worlds.push_back(entry.path());
  }
  std::sort(worlds.begin(), worlds.end());
  if (worlds.empty())
    return slamcore::NotFound(directory.string() + ": no floor plan (.txt) or map (.yaml) in it");
  return worlds;
}

}  // namespace sim
