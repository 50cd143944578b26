// A simulated home: an occupancy raster of walls, furniture and floor, rooms, and visual landmarks.
//
// Homes come from real data (see docs/fleetsim.md):
//  * apartment floor plans (vector walls, doors, rooms, fixtures; FloorplanTransformation annotations),
//    scaled at kFloorPlanMetresPerPixel; doors are carved out of the walls, fixtures become obstacles;
//  * occupancy maps of real homes mapped by robot vacuums (ROS map_server PGM + YAML).
// Furniture is then placed per room (beds in bedrooms, tables in living rooms and kitchens), and
// landmarks are put where a camera finds texture: pictures on walls (unique), fixtures (look-alike: every
// washing basin looks the same), and furniture, of which beds, tables and ceiling lamps are symmetric —
// seen from the opposite side they match with a 180°-wrong relative pose (paper IV-A). Where a robot can
// get stuck is laid out too (HomeClutter): plush rugs, whose borders catch the wheels, and low furniture
// (beds, sofas) the robot drives under and can wedge beneath.
//
// Thread safety: a World is immutable after loading; concurrent reads are safe.
#pragma once

#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "slamcore/se2.h"
#include "slamcore/status.h"

namespace sim {

using slamcore::SE2;
using slamcore::Vector2;

/// Metres per pixel of the floor-plan annotations, which carry no scale: the median door (49 px) is then
/// 0.78 m, the mean toilet 0.75 m long and the mean bathtub 1.22 m, as in real apartments.
inline constexpr double kFloorPlanMetresPerPixel = 0.016;

enum class Cell : std::uint8_t { kFree = 0, kOccupied = 1, kUnknown = 2 };

/// What covers a free cell, beside its occupancy: rugs and low furniture do not block the robot or its
/// ranging sensor, but their edges can stop the wheels, and under furniture the camera sees nothing.
enum class Surface : std::uint8_t { kFloor = 0, kRug = 1, kUnderFurniture = 2 };

/// How many rugs and low pieces of furniture a home has, and how easily they catch a robot
/// (docs/fleetsim.md "Stuck robots"):
///  * kTypical: a rug in a living room or bedroom with probability 0.5, elsewhere 0.2 (never in bathrooms,
///    kitchens or corridors); a bed the robot fits under in a bedroom with probability 0.3, a low sofa in a
///    living room with probability 0.3. Furniture with a clearance well above the robot catches it on 1 in 250
///    drives under its edge, a flat rug's border on 1 in 700 climbs.
///  * kHigh: two rugs in every living room and bedroom and one in every other room, a low bed in every
///    bedroom and a low sofa in every living room (and in every unlabelled room); the furniture's clearance
///    is just the robot's height (it catches on 3 in 20 drives under) and the rugs are deep-pile with tassels
///    (1 in 20 climbs).
enum class HomeClutter { kTypical, kHigh };
slamcore::Result<HomeClutter> ParseHomeClutter(const std::string& name);  // "typical" | "high"
const char* HomeClutterName(HomeClutter clutter);

/// A rug or a low piece of furniture: a rectangle of 2·half_size centred at `pose`, turned by its angle.
struct FloorFeature {
  std::string kind;  // "rug", "bed", "sofa"
  SE2 pose;
  Vector2 half_size;
  double catch_probability =
      0.0;  // per drive under it (furniture) or climb onto it (rug): the robot is stuck
  bool Contains(const Vector2& point) const;
};

class Grid {
 public:
  Grid() = default;
  Grid(int width, int height, double resolution, Vector2 origin, Cell fill);

  int width() const { return width_; }
  int height() const { return height_; }
  double resolution() const { return resolution_; }
  /// World coordinates of the corner of cell (0, 0); cell (i, j) covers x ∈ origin.x + [i, i+1)·resolution.
  const Vector2& origin() const { return origin_; }

  bool Contains(int i, int j) const { return i >= 0 && j >= 0 && i < width_ && j < height_; }
  Cell at(int i, int j) const { return Contains(i, j) ? cells_[Index(i, j)] : Cell::kUnknown; }
  void set(int i, int j, Cell cell) {
    if (Contains(i, j)) cells_[Index(i, j)] = cell;
  }
  Cell AtPoint(const Vector2& point) const;
  std::pair<int, int> CellOf(const Vector2& point) const;
  Vector2 CentreOf(int i, int j) const;

  /// True when a disc of `radius` at `point` touches no occupied or unknown cell.
  bool DiscIsFree(const Vector2& point, double radius) const;
  /// Distance along the ray to the first occupied or unknown cell, capped at max_range.
  double CastRay(const Vector2& from, double angle, double max_range) const;
  /// True when the straight segment crosses no occupied cell.
  bool LineOfSight(const Vector2& from, const Vector2& to) const;

 private:
  std::size_t Index(int i, int j) const { return static_cast<std::size_t>(j) * width_ + i; }
  int width_ = 0, height_ = 0;
  double resolution_ = 0.05;
  Vector2 origin_ = Vector2::Zero();
  std::vector<Cell> cells_;
};

struct Landmark {
  int id = 0;
  int appearance = 0;      // landmarks with equal appearance look alike to the front-end
  SE2 pose;                // world pose; x axis points where the textured face looks
  bool symmetric = false;  // looks the same from the opposite side (beds, tables, lamps)
  std::string kind;        // "picture", "washing_basin", "bed", …
  int room = -1;
};

struct Room {
  std::string label;  // "bedroom", "kitchen", … or "room" for maps without labels
  Vector2 seed;       // a free point inside
};

struct World {
  std::string name;
  Grid grid;
  std::vector<Room> rooms;
  std::vector<Landmark> landmarks;
  SE2 dock;  // where runs start: a free spot by a wall, facing into the room
  std::vector<FloorFeature> rugs, low_furniture;

  /// Under furniture wins over a rug; kFloor elsewhere.
  Surface SurfaceAt(const Vector2& point) const;
  /// The rug or piece of furniture at `point` (as SurfaceAt ranks them), or null.
  const FloorFeature* FeatureAt(const Vector2& point) const;

  /// Free cells (centres) a robot of `radius` fits on, for placing the robot and kidnaps.
  std::vector<Vector2> FreeSpots(double radius, std::size_t max_count, std::mt19937_64& random) const;
};

/// Loads one home file: a floor-plan annotation (.txt) or a map_server YAML (.yaml). Furniture and
/// landmarks are placed with `seed`, so the same file and seed give the same home.
slamcore::Result<World> LoadWorld(const std::filesystem::path& path, std::uint64_t seed,
                                  HomeClutter clutter = HomeClutter::kTypical);

/// Lays out rugs and low furniture in the rooms of `world` (LoadWorld does it; exposed for hand-made
/// worlds in tests). Each is placed only where all of it lies on free floor.
void PlaceFloorFeatures(World& world, HomeClutter clutter, std::mt19937_64& random);

/// Every home file in a directory (either kind), sorted by name; fails when there is none.
slamcore::Result<std::vector<std::filesystem::path>> ListWorlds(const std::filesystem::path& directory);

}  // namespace sim
