// Occupancy grids: the map as the robot and the fleet see it (paper IV-C works in this space).
//
//  * OccupancyGrid: a metric grid of cells -1 unknown, 0 free, 100 occupied (the LocalMapEvent and ROS
//    OccupancyGrid convention). Cell (col, row) covers [origin + col·res, origin + (col+1)·res) in x and the
//    same in y with row 0 at the LOWEST y, as in ROS. Images (PGM, PNG) have row 0 at the TOP, so readers
//    and writers flip rows; ImageRowOf() converts.
//  * ROS map_server PGM + YAML read/write (trinary mode: 254 free, 0 occupied, 205 unknown on write;
//    occupied_thresh / free_thresh / negate honoured on read), and PNG read/write of the same image.
//  * GlobalGridRenderer: the global grid rendered from Map::local_maps at the nodes' current poses.
//
// Error contract: every reader returns a Status naming the file and what was wrong (corrupt header,
// truncated pixels, absurd size, missing key); nothing here crashes on bad input.
// Thread safety: value types; a GlobalGridRenderer is used from one thread.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "slamcore/events.h"
#include "slamcore/pose_graph.h"
#include "slamcore/status.h"

namespace slamcore {

struct Map;  // mapper.h: the pose graph and the local maps attached to its nodes

enum class CellState : std::int8_t { kUnknown = -1, kFree = 0, kOccupied = 100 };

/// The largest grid any reader or renderer accepts: 20000 cells on a side and 10^8 cells in all
/// (a 1 km × 1 km home at 5 cm is 4·10^8; nothing real comes close to these).
inline constexpr int kMaxGridSide = 20000;
inline constexpr std::int64_t kMaxGridCells = 100'000'000;

struct OccupancyGrid {
  double resolution = 0.05;  // metres per cell
  double origin_x = 0.0;     // world position of the lower-left corner of cell (0, 0)
  double origin_y = 0.0;
  double origin_yaw = 0.0;  // kept from map_server YAML; alignment requires equal yaws
  int width = 0;
  int height = 0;
  std::vector<std::int8_t> cells;  // row-major, row 0 = lowest y

  /// A width × height grid of unknown cells; fails on non-positive or absurd sizes or resolution.
  static Result<OccupancyGrid> Create(int width, int height, double resolution, double origin_x = 0.0,
                                      double origin_y = 0.0);

  bool InBounds(int col, int row) const { return col >= 0 && row >= 0 && col < width && row < height; }
  std::int8_t at(int col, int row) const { return cells[static_cast<std::size_t>(row) * width + col]; }
  std::int8_t& at(int col, int row) { return cells[static_cast<std::size_t>(row) * width + col]; }
  /// Row in an image (PGM/PNG, row 0 at the top) of grid row `row`, and back (the map is its own inverse).
  int ImageRowOf(int row) const { return height - 1 - row; }
  std::int64_t CountCells(CellState state) const;
};

/// Reads a ROS map_server YAML file and the image it names (PGM P5/P2, or PNG), relative to the YAML's
/// directory. Strict: unknown keys are ignored, but image, resolution and origin are required and checked.
Result<OccupancyGrid> ReadMapServerYaml(const std::string& yaml_path);
/// The same for YAML text held in memory (an upload): `read_image` gets the image's name as the YAML writes
/// it (unquoted) and returns its bytes, or an error (e.g. a name that is not part of the upload). Errors are
/// prefixed with `source`; malformed YAML is DATA_LOSS, as for files.
Result<OccupancyGrid> ParseMapServerYaml(
    const std::string& yaml_text, const std::string& source,
    const std::function<Result<std::string>(const std::string& image)>& read_image);
/// Writes `yaml_path` and an image beside it (same stem, .pgm, or .png when `png` is true).
Status WriteMapServerYaml(const OccupancyGrid& grid, const std::string& yaml_path, bool png = false);
/// The YAML text map_server reads for `grid` stored in `image_file` (a name relative to the YAML).
std::string MapServerYaml(const OccupancyGrid& grid, const std::string& image_file);

/// Decodes an 8-bit PGM (P5 binary or P2 ASCII, maxval ≤ 255) into a grid with map_server thresholds.
Result<OccupancyGrid> DecodePgm(const std::string& bytes, double resolution, double origin_x, double origin_y,
                                double occupied_thresh = 0.65, double free_thresh = 0.196,
                                bool negate = false);
std::string EncodePgm(const OccupancyGrid& grid);
/// PNG of the same trinary image (254/0/205), through OpenCV's codec; colour PNGs are converted to grey.
Result<OccupancyGrid> DecodePng(const std::string& bytes, double resolution, double origin_x, double origin_y,
                                double occupied_thresh = 0.65, double free_thresh = 0.196,
                                bool negate = false);
Result<std::string> EncodePng(const OccupancyGrid& grid);

/// A whole file; refused (naming the file and both sizes) when larger than `max_bytes`, before it is read.
Result<std::string> ReadFileBytes(const std::string& path,
                                  std::uintmax_t max_bytes = std::uintmax_t{1} << 31);
Status WriteFileBytes(const std::string& path, const std::string& bytes);

/// Checks that node `node`'s local map can be read cell by cell: a size within kMaxGridSide, width × height
/// cells and a positive, finite resolution. Every reader of patches (the renderer, slip detection) asks it.
Status ValidateLocalMap(NodeId node, const LocalMapEvent& patch);

/// The cell rule of every grid drawn from votes (the renderer's, and the protrusion generator's scans): a
/// cell is occupied when it has an occupied vote and occupied votes are at least half its free votes, free
/// when it has only or mostly free votes, unknown without votes.
constexpr CellState CellFromVotes(std::int64_t occupied, std::int64_t free) {
  if (occupied > 0 && 2 * occupied >= free) return CellState::kOccupied;
  return free > 0 ? CellState::kFree : CellState::kUnknown;
}

/// Renders the global grid of a Map from its local patches at the nodes' current poses (paper II/IV-C:
/// the occupancy map is a function of the graph, so it must follow every optimisation).
///
/// Each patch cell votes free or occupied into the global cells it covers (inverse mapping, so rotated
/// patches leave no holes); CellFromVotes decides each global cell.
///
/// A ray does not pass through a wall. A patch is what the sensor saw from its node, so a patch whose free
/// cells cover a wall the map agrees on (a cell drawn occupied by the rule above, with at least kWallVotes
/// occupied votes) is misplaced along those bearings: a node turned by a few degrees puts a lidar's ray ends tens of
/// centimetres beyond the wall it hit. Such a patch's votes along a bearing farther than kWallTolerance cells
/// past the first agreed wall its free cells cover are withdrawn (the first two cells past it still count): the inverse sensor model of occupancy grid
/// mapping (a beam tells nothing past the first obstacle; Moravec & Elfes 1985, Thrun et al., Probabilistic
/// Robotics, ch. 9) applied across patches, with the map's agreed walls as the obstacles. The agreed walls are taken from all votes before any is withdrawn, so the result does not depend on
/// the order of the patches. Without it, the outermost of many slightly turned patches sets a home's edge: a
/// lifelong map grows false floor outside its walls run after run.
class GlobalGridRenderer {
 public:
  /// A wall that blocks rays has at least this many occupied votes (one patch's wall is not agreement).
  static constexpr int kWallVotes = 2;
  /// Votes within this many cells past the first agreed wall along their bearing still count: a wall drawn
  /// by many patches is a few cells thick, and a patch's own wall lies just behind its free cells. Not a
  /// whole number, so that cells along an axis are never on the boundary.
  static constexpr double kWallTolerance = 2.5;

  explicit GlobalGridRenderer(double resolution = 0.05, double margin_m = 2.0)
      : resolution_(resolution), margin_m_(margin_m) {}

  /// Bounds are the union of all patches plus the margin.
  Status RenderAll(const Map& map);

  const OccupancyGrid& grid() const { return grid_; }
  double resolution() const { return resolution_; }  // metres per cell of the grids it renders

 private:
  /// The empty grid whose bounds are the union of the map's patches plus the margin.
  Result<OccupancyGrid> Bounds(const Map& map) const;

  double resolution_;
  double margin_m_;
  OccupancyGrid grid_;
};

}  // namespace slamcore
