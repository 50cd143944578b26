// Erroneous-protrusion detection: difference, clean-up, regions and features (paper IV-C; see the header).
#include "slamcore/protrusion_detector.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <optional>

namespace slamcore {
namespace {

constexpr std::int8_t kFree = static_cast<std::int8_t>(CellState::kFree);
constexpr std::int8_t kOccupied = static_cast<std::int8_t>(CellState::kOccupied);
constexpr std::int8_t kUnknown = static_cast<std::int8_t>(CellState::kUnknown);

Status CheckGrid(const OccupancyGrid& grid, const char* which) {
  const std::string name(which);
  if (grid.width <= 0 || grid.height <= 0) return InvalidArgument(name + " map is empty");
  if (grid.width > kMaxGridSide || grid.height > kMaxGridSide ||
      static_cast<std::int64_t>(grid.width) * grid.height > kMaxGridCells) {
    return InvalidArgument(name + " map has an absurd size");
  }
  if (grid.cells.size() != static_cast<std::size_t>(grid.width) * grid.height) {
    return InvalidArgument(name + " map: cells do not match width x height");
  }
  if (!(grid.resolution > 0.0) || !std::isfinite(grid.resolution)) {
    return InvalidArgument(name + " map: bad resolution");
  }
  return Status::Ok();
}

/// What every region's features look up in the whole pair. Each part is computed near the regions that
/// ask for it, so that the cost follows the changes, not the size of the map.
class PairContext {
 public:
  PairContext(const cv::Mat& child_cells, const cv::Mat& parent_cells)
      : child_cells_(child_cells), parent_cells_(parent_cells) {}

  /// CV_8U over `where`: 255 where the aligned parent, dilated by one cell, has a wall.
  cv::Mat ParentWalls(const cv::Rect& where) const {
    const cv::Rect grown = Grown(where, 1);
    cv::Mat walls;
    cv::dilate(parent_cells_(grown) == kOccupied, walls, cv::Mat::ones(3, 3, CV_8U));
    return walls(cv::Rect(where.x - grown.x, where.y - grown.y, where.width, where.height)).clone();
  }
  /// CV_8U over `where`: 255 where the aligned parent has floor.
  cv::Mat ParentFloor(const cv::Rect& where) const { return parent_cells_(where) == kFree; }
  cv::Rect Bounds() const { return cv::Rect(0, 0, child_cells_.cols, child_cells_.rows); }

  /// Whether the child's floor cell (col, row) is reachable: connected (4-neighbours) to the parent's floor
  /// through child floor the parent did not hold as a wall. A robot reaches new floor from known floor
  /// through a gap; a stuck robot's band lies beyond the wall it pushed. A flood from the cell stops at the
  /// first known floor, and every cell it visited is then classed, so no cell is flooded twice.
  bool Reachable(int col, int row) {
    if (reach_.empty()) reach_.assign(child_cells_.total(), kUnvisited);
    const auto index = [&](int c, int r) { return static_cast<std::size_t>(r) * child_cells_.cols + c; };
    if (reach_[index(col, row)] != kUnvisited) return reach_[index(col, row)] == kReachable;
    if (!Passable(col, row)) return false;
    std::vector<cv::Point>& visited = flood_;
    visited.assign(1, cv::Point(col, row));
    reach_[index(col, row)] = kQueued;
    bool reachable = false;
    for (std::size_t next = 0; next < visited.size() && !reachable; ++next) {
      const cv::Point cell = visited[next];
      if (parent_cells_.at<std::int8_t>(cell.y, cell.x) == kFree) {
        reachable = true;
        break;
      }
      for (const cv::Point step : {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)}) {
        const cv::Point neighbour = cell + step;
        if (neighbour.x < 0 || neighbour.y < 0 || neighbour.x >= child_cells_.cols ||
            neighbour.y >= child_cells_.rows || !Passable(neighbour.x, neighbour.y)) {
          continue;
        }
        std::uint8_t& state = reach_[index(neighbour.x, neighbour.y)];
        if (state == kReachable) {
          reachable = true;
          break;
        }
        if (state == kUnvisited) {
          state = kQueued;
          visited.push_back(neighbour);
        }
      }
    }
    // A flood that stopped early visited part of a reachable component; one that ran out, all of an
    // unreachable one.
    for (const cv::Point cell : visited)
      reach_[index(cell.x, cell.y)] = reachable ? kReachable : kUnreachable;
    return reachable;
  }

 private:
  static constexpr std::uint8_t kUnvisited = 0, kQueued = 1, kReachable = 2, kUnreachable = 3;

  bool Passable(int col, int row) const {
    return child_cells_.at<std::int8_t>(row, col) == kFree &&
           parent_cells_.at<std::int8_t>(row, col) != kOccupied;
  }
  cv::Rect Grown(const cv::Rect& where, int by) const {
    return cv::Rect(where.x - by, where.y - by, where.width + 2 * by, where.height + 2 * by) & Bounds();
  }

  cv::Mat child_cells_, parent_cells_;
  std::vector<std::uint8_t> reach_;  // per child cell, one of the k* states; allocated when first asked
  std::vector<cv::Point> flood_;
};

/// Repetition of the surroundings: the translation (0.3–6 m) under which the region's walls and floor best
/// land on the parent's walls and floor, and how well they do. A stuck robot draws copies of what it sees
/// shifted along its push, so its band matches the parent shifted back; a new room's layout rarely does.
struct ShiftMatch {
  double walls = 0.0, floor = 0.0;  // shares of the region's wall / floor cells explained at the best shift
  double distance_m = 0.0;
  double angle = 0.0;  // of the best shift, radians in the image frame
};

ShiftMatch BestShift(const cv::Mat& region_walls, const cv::Mat& region_floor, const cv::Rect& where,
                     const PairContext& context, double resolution) {
  ShiftMatch best;
  const double wall_cells = cv::countNonZero(region_walls), floor_cells = cv::countNonZero(region_floor);
  if (wall_cells + floor_cells < 1.0) return best;
  // Matched on a grid of at least 10 cm, and coarser for big regions (≤ ~100 cells a side), so the cost
  // stays bounded; walls are dilated by a cell first, so the coarse grid still sees them.
  const int factor = std::max({1, static_cast<int>(std::floor(0.1 / resolution + 1e-9)),
                               static_cast<int>(std::ceil(std::max(where.width, where.height) / 100.0))});
  const int reach = static_cast<int>(std::ceil(6.0 / resolution));
  const cv::Rect window(where.x - reach, where.y - reach, where.width + 2 * reach, where.height + 2 * reach);
  const cv::Rect inside = window & context.Bounds();
  auto crop = [&](const cv::Mat& image) {
    cv::Mat padded = cv::Mat::zeros(window.size(), CV_32F);
    image.convertTo(padded(cv::Rect(inside.x - window.x, inside.y - window.y, inside.width, inside.height)),
                    CV_32F, 1.0 / 255.0);
    if (factor > 1) cv::resize(padded, padded, {}, 1.0 / factor, 1.0 / factor, cv::INTER_AREA);
    return padded;
  };
  auto templ = [&](const cv::Mat& mask) {
    cv::Mat out;
    mask.convertTo(out, CV_32F, 1.0 / 255.0);
    if (factor > 1) cv::resize(out, out, {}, 1.0 / factor, 1.0 / factor, cv::INTER_AREA);
    return out;
  };
  const cv::Mat walls_image = crop(context.ParentWalls(inside)),
                floor_image = crop(context.ParentFloor(inside));
  const cv::Mat walls_template = templ(region_walls), floor_template = templ(region_floor);
  if (walls_template.cols > walls_image.cols || walls_template.rows > walls_image.rows) return best;
  cv::Mat wall_scores, floor_scores;
  cv::matchTemplate(walls_image, walls_template, wall_scores, cv::TM_CCORR);
  cv::matchTemplate(floor_image, floor_template, floor_scores, cv::TM_CCORR);
  const double wall_total = std::max(1e-9, cv::sum(walls_template)[0]);
  const double floor_total = std::max(1e-9, cv::sum(floor_template)[0]);
  const double centre_x = (where.x - window.x) / static_cast<double>(factor);
  const double centre_y = (where.y - window.y) / static_cast<double>(factor);
  const double min_shift = 0.3 / (resolution * factor);
  double best_score = -1.0;
  for (int row = 0; row < wall_scores.rows; ++row) {
    for (int col = 0; col < wall_scores.cols; ++col) {
      const double dx = col - centre_x, dy = row - centre_y;
      if (std::hypot(dx, dy) < min_shift) continue;
      const double walls = wall_cells > 0 ? std::min(1.0, wall_scores.at<float>(row, col) / wall_total) : 0.0;
      const double floor =
          floor_cells > 0 ? std::min(1.0, floor_scores.at<float>(row, col) / floor_total) : 0.0;
      const double score = (wall_cells > 0 ? walls : floor) + (floor_cells > 0 ? floor : walls);
      if (score > best_score) {
        best_score = score;
        best = {walls, floor, std::hypot(dx, dy) * factor * resolution, std::atan2(dy, dx)};
      }
    }
  }
  return best;
}

/// The features of one region, `mask` being its cleaned cells inside `roi` (1 inside, 0 outside) with at
/// least one cell of margin on every side; `roi` is where mask's inner part lies in the child's image.
std::vector<double> RegionFeatures(const cv::Mat& mask, const cv::Mat& child_roi, const cv::Mat& parent_roi,
                                   const cv::Rect& roi, PairContext& context, double resolution) {
  const double r = resolution, r2 = resolution * resolution;
  const double area = cv::countNonZero(mask);
  const cv::Rect box = cv::boundingRect(mask);
  const double bbox_area = static_cast<double>(box.area());

  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  double perimeter = 0.0;
  std::vector<cv::Point> all_points;
  for (const auto& contour : contours) {
    perimeter += cv::arcLength(contour, true);
    all_points.insert(all_points.end(), contour.begin(), contour.end());
  }
  std::vector<cv::Point> hull;
  if (!all_points.empty()) cv::convexHull(all_points, hull);
  // Hull polygons pass through pixel centres; half the hull's perimeter plus one restores the pixel area.
  const double hull_area =
      hull.size() >= 3 ? cv::contourArea(hull) + 0.5 * cv::arcLength(hull, true) + 1.0 : area;
  const double solidity = std::min(1.0, area / std::max(hull_area, 1.0));

  // Second moments as regionprops does: the ellipse with the region's normalised central moments.
  const cv::Moments moments = cv::moments(mask, true);
  const double mu20 = moments.mu20 / area + 1.0 / 12.0, mu02 = moments.mu02 / area + 1.0 / 12.0;
  const double mu11 = moments.mu11 / area;
  const double common = std::sqrt((mu20 - mu02) * (mu20 - mu02) + 4.0 * mu11 * mu11);
  const double major = 2.0 * std::sqrt(2.0) * std::sqrt(std::max(0.0, mu20 + mu02 + common));
  const double minor = 2.0 * std::sqrt(2.0) * std::sqrt(std::max(0.0, mu20 + mu02 - common));

  // Distance transform inside the region: half the local width. A slip corridor is one robot wide
  // everywhere; a room or a revealed floor patch is wide somewhere (the paper's strongest feature).
  cv::Mat distance;
  cv::distanceTransform(mask, distance, cv::DIST_L2, cv::DIST_MASK_5);
  double max_distance = 0.0;
  cv::minMaxLoc(distance, nullptr, &max_distance, nullptr, nullptr, mask);
  const double mean_distance = cv::mean(distance, mask)[0];

  // Contact with the parent: region boundary cells next to cells the parent knew to be free. A slip
  // corridor touches known space only where the robot got stuck, one robot-width wide.
  cv::Mat eroded, boundary, parent_free, near_parent_free, contact;
  cv::erode(mask, eroded, cv::getStructuringElement(cv::MORPH_CROSS, {3, 3}));
  cv::subtract(mask, eroded, boundary);
  cv::compare(parent_roi, kFree, parent_free, cv::CMP_EQ);
  cv::dilate(parent_free, near_parent_free, cv::Mat::ones(3, 3, CV_8U));
  cv::bitwise_and(boundary, near_parent_free, contact);
  const double boundary_cells = std::max(1, cv::countNonZero(boundary));
  const double contact_cells = cv::countNonZero(contact);

  cv::Mat child_walls, parent_walls, child_floor;
  cv::compare(child_roi, kOccupied, child_walls, cv::CMP_EQ);
  cv::compare(parent_roi, kOccupied, parent_walls, cv::CMP_EQ);
  cv::compare(child_roi, kFree, child_floor, cv::CMP_EQ);
  cv::bitwise_and(child_walls, mask, child_walls);
  cv::bitwise_and(child_floor, mask, child_floor);
  // Walls crossed: cells the parent held as walls that the child now has as floor (a door opened, or a
  // stuck robot's band drawn through the wall it pushed).
  cv::Mat crossed;
  cv::bitwise_and(parent_walls, child_floor, crossed);
  cv::bitwise_and(parent_walls, mask, parent_walls);

  // Boundary against the parent's walls: a band beyond a wall lies along it.
  cv::Mat near_parent_walls, wall_contact;
  cv::dilate(parent_roi == kOccupied, near_parent_walls, cv::Mat::ones(3, 3, CV_8U));
  cv::bitwise_and(boundary, near_parent_walls, wall_contact);

  // The mask's inner part (without the 1-cell pad) in the child's image, for the pair-wide lookups.
  const cv::Rect inner(1, 1, roi.width, roi.height);
  const cv::Mat floor_inner = child_floor(inner);
  double reachable_cells = 0.0;
  for (int row = 0; row < floor_inner.rows; ++row) {
    const std::uint8_t* floor = floor_inner.ptr<std::uint8_t>(row);
    for (int col = 0; col < floor_inner.cols; ++col) {
      if (floor[col] && context.Reachable(roi.x + col, roi.y + row)) ++reachable_cells;
    }
  }
  const double floor_cells = cv::countNonZero(child_floor);
  const ShiftMatch shift = BestShift(child_walls(inner), child_floor(inner), roi, context, resolution);
  // Image rows grow downwards; the moments' axis angle is in the same image frame.
  const double axis = 0.5 * std::atan2(2.0 * mu11, mu20 - mu02);
  const double shift_alignment = std::abs(std::cos(shift.angle - axis));

  return {area * r2,
          bbox_area * r2,
          perimeter * r,
          major * r,
          minor * r,
          mean_distance * r,
          max_distance * r,
          major / std::max(minor, 1e-9),
          solidity,
          area / std::max(bbox_area, 1.0),
          contact_cells * r,
          contact_cells / boundary_cells,
          cv::countNonZero(child_walls) / area,
          cv::countNonZero(parent_walls) / area,
          floor_cells > 0 ? reachable_cells / floor_cells : 0.0,
          cv::countNonZero(wall_contact) / boundary_cells,
          cv::countNonZero(crossed) * r2,
          shift.walls,
          shift.floor,
          shift.distance_m,
          shift_alignment};
}

/// The cells of the difference (DifferenceMask) that a registration error of `tolerance_cells` explains
/// (CV_8U, non-zero = explained): a newly known cell within the tolerance of a cell the parent knew (the same
/// edge drawn a little farther out), a wall turned floor within it of a child wall (the same wall drawn a
/// little to one side). `raw` is the difference; two dilations by the Euclidean disk, once per pair.
cv::Mat ExplainedByRegistrationError(const cv::Mat& raw, const cv::Mat& child_cells,
                                     const cv::Mat& parent_cells, double tolerance_cells) {
  const int radius = static_cast<int>(std::floor(tolerance_cells));
  cv::Mat disk = cv::Mat::zeros(2 * radius + 1, 2 * radius + 1, CV_8U);
  for (int row = -radius; row <= radius; ++row) {
    for (int col = -radius; col <= radius; ++col) {
      if (row * row + col * col <= tolerance_cells * tolerance_cells)
        disk.at<std::uint8_t>(row + radius, col + radius) = 1;
    }
  }
  cv::Mat near_parent_known, near_child_wall;
  cv::dilate(parent_cells != kUnknown, near_parent_known, disk);
  cv::dilate(child_cells == kOccupied, near_child_wall, disk);
  // A cell of the difference is newly known where the parent knew nothing, else a wall turned floor.
  const cv::Mat newly_known = parent_cells == kUnknown;
  return (raw != 0) & ((newly_known & near_parent_known) | (~newly_known & near_child_wall));
}

/// The walls turned floor that are a change and not the same wall drawn beside itself: those the
/// registration error does not explain (a doorway's middle, a band's hole), grown back by the tolerance
/// within the wall (to the doorway's jambs). A CV_8U mask over the child image; every wall turned floor
/// when there is no tolerance (`explained` empty).
cv::Mat WallsOpened(const cv::Mat& child_cells, const cv::Mat& parent_cells, double tolerance_cells,
                    const cv::Mat& explained) {
  const cv::Mat crossed = (child_cells == kFree) & (parent_cells == kOccupied);
  if (explained.empty() || cv::countNonZero(crossed) == 0) return crossed;
  cv::Mat opened = crossed & (explained == 0);
  const int grow = static_cast<int>(std::ceil(tolerance_cells));
  cv::dilate(opened, opened, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * grow + 1, 2 * grow + 1}));
  return opened & crossed;
}

/// The clean-up's images over a window of the pair (CV_8U, non-zero = set): the difference's cells that the
/// registration error explains (empty without a tolerance), the difference opened by the clean-up kernel,
/// and the walls opened (WallsOpened). Each cell's value depends on cells within a kernel or twice the
/// tolerance of it, so a window that reaches that far past a region gives the region's cells the values a
/// computation over the whole pair gives them.
struct CleanUpImages {
  cv::Rect window;
  cv::Mat explained, opened, walls_opened;

  /// `roi` of the pair (inside the window) in the images' own coordinates.
  cv::Rect Within(const cv::Rect& roi) const {
    return cv::Rect(roi.x - window.x, roi.y - window.y, roi.width, roi.height);
  }
};

CleanUpImages CleanUpOver(const cv::Rect& window, const cv::Mat& raw, const cv::Mat& child_cells,
                          const cv::Mat& parent_cells, const cv::Mat& opening_kernel,
                          double tolerance_cells) {
  CleanUpImages images;
  images.window = window;
  const cv::Mat raw_window = raw(window), child_window = child_cells(window),
                parent_window = parent_cells(window);
  if (tolerance_cells > 0.0) {
    images.explained = ExplainedByRegistrationError(raw_window, child_window, parent_window, tolerance_cells);
  }
  if (opening_kernel.rows >= 2) {
    cv::morphologyEx(raw_window, images.opened, cv::MORPH_OPEN, opening_kernel);
  } else {
    images.opened = raw_window;
  }
  images.walls_opened = WallsOpened(child_window, parent_window, tolerance_cells, images.explained);
  return images;
}

/// One region's cells that survive the clean-up (CV_8U, 255 = kept) over `roi`, a rectangle around it
/// inside the images' window: its opened cells (the whole difference's opening on a region's cells is the
/// region's own: a kernel square of difference cells is connected, so it lies in one region), and its walls
/// opened that form pieces of at least `min_cells`. Walls that became floor survive whatever their
/// thickness: a wall is one or two cells thick, and a hole in it (a door opened, a stuck robot's band drawn
/// through it) is a change, not speckle. A piece lies inside its region (pieces are connected difference
/// cells), so it is measured there.
cv::Mat CleanedRegion(const cv::Mat& in_region, const CleanUpImages& images, const cv::Rect& roi,
                      double min_cells) {
  cv::Mat clean = (images.opened(images.Within(roi)) != 0) & in_region;
  const cv::Mat opened_walls = (images.walls_opened(images.Within(roi)) != 0) & in_region;
  cv::Mat piece_labels, piece_stats, unused;
  const int pieces =
      cv::connectedComponentsWithStats(opened_walls, piece_labels, piece_stats, unused, 8, CV_32S);
  for (int piece = 1; piece < pieces; ++piece) {
    if (piece_stats.at<int>(piece, cv::CC_STAT_AREA) < min_cells) continue;
    clean.setTo(255, piece_labels == piece);
  }
  return clean;
}

}  // namespace

const std::vector<std::string>& ProtrusionFeatureNames() {
  static const std::vector<std::string> kNames = {"area_m2",
                                                  "bbox_area_m2",
                                                  "perimeter_m",
                                                  "major_axis_m",
                                                  "minor_axis_m",
                                                  "mean_distance_m",
                                                  "max_distance_m",
                                                  "elongation",
                                                  "solidity",
                                                  "extent",
                                                  "contact_length_m",
                                                  "contact_fraction",
                                                  "wall_fraction",
                                                  "parent_wall_fraction",
                                                  "reachable_fraction",
                                                  "wall_contact_fraction",
                                                  "crossed_wall_m2",
                                                  "shift_wall_match",
                                                  "shift_floor_match",
                                                  "shift_distance_m",
                                                  "shift_alignment"};
  return kNames;
}

Result<OccupancyGrid> AlignParentToChild(const OccupancyGrid& parent, const OccupancyGrid& child) {
  RETURN_IF_ERROR(CheckGrid(parent, "parent"));
  RETURN_IF_ERROR(CheckGrid(child, "child"));
  const double resolution = child.resolution;
  if (std::abs(parent.resolution - resolution) > 1e-9 * resolution) {
    return InvalidArgument("parent and child maps have different resolutions (" +
                           std::to_string(parent.resolution) + " vs " + std::to_string(resolution) +
                           " m/cell); re-save one at the other's resolution");
  }
  if (std::abs(WrapAngle(parent.origin_yaw - child.origin_yaw)) > 1e-9) {
    return InvalidArgument(
        "parent and child maps have different origin yaws; they cannot be aligned cell to cell");
  }
  const double dx = (parent.origin_x - child.origin_x) / resolution;
  const double dy = (parent.origin_y - child.origin_y) / resolution;
  if (std::abs(dx - std::round(dx)) > 1e-3 || std::abs(dy - std::round(dy)) > 1e-3) {
    return InvalidArgument("parent and child origins are not a whole number of cells apart (" +
                           std::to_string(dx) + ", " + std::to_string(dy) +
                           " cells); the maps are not on the same grid");
  }
  if (std::abs(dx) > 4.0 * kMaxGridSide || std::abs(dy) > 4.0 * kMaxGridSide) {
    return InvalidArgument("parent and child origins are absurdly far apart");
  }
  const int shift_x = static_cast<int>(std::lround(dx)), shift_y = static_cast<int>(std::lround(dy));
  ASSIGN_OR_RETURN(auto aligned, OccupancyGrid::Create(child.width, child.height, resolution, child.origin_x,
                                                       child.origin_y));
  aligned.origin_yaw = child.origin_yaw;
  const int col_begin = std::max(0, shift_x), col_end = std::min(child.width, shift_x + parent.width);
  if (col_begin < col_end) {
    for (int row = std::max(0, shift_y); row < std::min(child.height, shift_y + parent.height); ++row) {
      const auto source = parent.cells.begin() + static_cast<std::ptrdiff_t>(row - shift_y) * parent.width;
      std::copy(source + (col_begin - shift_x), source + (col_end - shift_x),
                aligned.cells.begin() + static_cast<std::ptrdiff_t>(row) * child.width + col_begin);
    }
  }
  return aligned;
}

std::vector<std::uint8_t> DifferenceMask(const OccupancyGrid& aligned_parent, const OccupancyGrid& child) {
  std::vector<std::uint8_t> mask(child.cells.size(), 0);
  // Plain pointers and operators that do not short-circuit: a loop without branches or reloads, which
  // the compiler vectorises (the output cannot alias the grids' cells).
  const std::int8_t* before = aligned_parent.cells.data();
  const std::int8_t* now = child.cells.data();
  std::uint8_t* out = mask.data();
  const std::size_t size = mask.size();
#pragma GCC ivdep
  for (std::size_t i = 0; i < size; ++i) {
    out[i] = static_cast<std::uint8_t>(((now[i] != kUnknown) & (before[i] == kUnknown)) |
                                       ((now[i] == kFree) & (before[i] == kOccupied)));
  }
  return mask;
}

Result<std::vector<ProtrusionRegion>> ExtractRegions(const OccupancyGrid& parent, const OccupancyGrid& child,
                                                     const DetectorOptions& options) {
  // Size and resolution first: a map in the wrong unit fails them before its origins look absurdly far.
  if (static_cast<std::int64_t>(child.width) * child.height > kMaxDetectorCells) {
    return InvalidArgument("the child map has " + std::to_string(child.width) + " x " +
                           std::to_string(child.height) + " cells, more than the " +
                           std::to_string(kMaxDetectorCells) + " the protrusion detector takes");
  }
  if (child.resolution < kMinDetectorResolutionM) {
    return InvalidArgument("maps at " + MessageNumber(child.resolution * 1000.0) +
                           " mm per cell are finer than the " +
                           MessageNumber(kMinDetectorResolutionM * 1000.0) +
                           " mm the protrusion detector takes; check the map's resolution (metres per cell)");
  }
  ASSIGN_OR_RETURN(auto aligned, AlignParentToChild(parent, child));
  if (!(options.clean_up_size_m >= 0.0) || !(options.min_region_area_m2 >= 0.0) ||
      !(options.registration_tolerance_m >= 0.0)) {
    return InvalidArgument("detector options must be non-negative");
  }
  // Its disk is dilated around every region: bounded, and a tolerance past a metre would hide rooms.
  if (options.registration_tolerance_m > kMaxRegistrationToleranceM) {
    return InvalidArgument("detector: registration tolerance above " +
                           std::to_string(kMaxRegistrationToleranceM) + " m");
  }
  const double r = child.resolution;
  // 0.15 / 0.05 is 2.99…: a hair more, so that three cells are within 0.15 m.
  const double tolerance_cells =
      options.registration_tolerance_m > 0.0 ? options.registration_tolerance_m / r + 1e-6 : 0.0;
  std::vector<std::uint8_t> difference = DifferenceMask(aligned, child);
  const cv::Mat raw(child.height, child.width, CV_8U, difference.data());
  // The grids' int8 cells viewed as images, without copies (OpenCV only reads them).
  const cv::Mat child_cells(child.height, child.width, CV_8S, const_cast<std::int8_t*>(child.cells.data()));
  const cv::Mat parent_cells(child.height, child.width, CV_8S, aligned.cells.data());

  // Regions are the connected components of the RAW difference, described by their cells that survive
  // the clean-up: an opening cuts a room at a narrow neck, but the pieces are still one change.
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(raw, labels, stats, centroids, 8, CV_32S);
  PairContext context(child_cells, parent_cells);
  const double min_cells = std::max(1.0, options.min_region_area_m2 / (r * r));
  // An odd kernel, so that the opening is centred and does not shift regions by half a cell.
  const int kernel = static_cast<int>(std::lround(options.clean_up_size_m / r)) | 1;
  const cv::Mat opening_kernel = cv::Mat::ones(kernel, kernel, CV_8U);
  const cv::Mat dilation_kernel = cv::Mat::ones(2 * kernel + 1, 2 * kernel + 1, CV_8U);
  const int pad = kernel + 1;
  // The clean-up of each region needs its images within a window around it, wide enough that nothing
  // beyond it can change them: the opening reaches a kernel, the registration test its tolerance from each
  // cell it judges, and those cells lie up to a tolerance beyond the region (the walls opened are grown
  // back by it). Windows follow the changes, so a large map with a few changes costs what they cost; when
  // the windows would cover more than the pair (many regions close together), the images are made once.
  const int work_pad = pad + 2 * static_cast<int>(std::ceil(tolerance_cells)) + 1;
  const cv::Rect bounds(0, 0, child.width, child.height);
  // A region's bounding box grown by `by` cells on every side, within the pair.
  const auto around = [&](int label, int by) {
    const int x = stats.at<int>(label, cv::CC_STAT_LEFT), y = stats.at<int>(label, cv::CC_STAT_TOP);
    const int w = stats.at<int>(label, cv::CC_STAT_WIDTH), h = stats.at<int>(label, cv::CC_STAT_HEIGHT);
    return cv::Rect(x - by, y - by, w + 2 * by, h + 2 * by) & bounds;
  };
  double window_cells = 0.0;
  for (int label = 1; label < count; ++label) {
    if (stats.at<int>(label, cv::CC_STAT_AREA) >= min_cells) window_cells += around(label, work_pad).area();
  }
  std::optional<CleanUpImages> whole_pair;
  if (window_cells > bounds.area()) {
    whole_pair = CleanUpOver(bounds, raw, child_cells, parent_cells, opening_kernel, tolerance_cells);
  }

  std::vector<ProtrusionRegion> regions;
  for (int label = 1; label < count; ++label) {
    if (stats.at<int>(label, cv::CC_STAT_AREA) < min_cells) continue;  // too small even before clean-up
    const cv::Rect roi = around(label, pad);
    const CleanUpImages images = whole_pair ? *whole_pair
                                            : CleanUpOver(around(label, work_pad), raw, child_cells,
                                                          parent_cells, opening_kernel, tolerance_cells);
    const cv::Mat clean = CleanedRegion(labels(roi) == label, images, roi, min_cells);
    // A padded copy so that the distance transform and contours see background around the region.
    cv::Mat mask = cv::Mat::zeros(roi.height + 2, roi.width + 2, CV_8U);
    cv::Mat mask_inner = mask(cv::Rect(1, 1, roi.width, roi.height));
    clean.copyTo(mask_inner);
    const int area = cv::countNonZero(mask_inner);
    if (area < min_cells) continue;
    // A region with any cell beyond the registration error is kept whole (a fragment of a real change near
    // known space keeps its shape); one that registration explains entirely is no change.
    if (!images.explained.empty() &&
        cv::countNonZero(mask_inner & (images.explained(images.Within(roi)) == 0)) == 0) {
      continue;
    }
    const cv::Rect local = cv::boundingRect(mask_inner);
    const cv::Rect inner(roi.x + local.x, roi.y + local.y, local.width, local.height);
    cv::Mat child_roi = cv::Mat::zeros(mask.size(), CV_8S),
            parent_roi = cv::Mat(mask.size(), CV_8S, cv::Scalar(-1));
    child_cells(roi).copyTo(child_roi(cv::Rect(1, 1, roi.width, roi.height)));
    parent_cells(roi).copyTo(parent_roi(cv::Rect(1, 1, roi.width, roi.height)));

    ProtrusionRegion region;
    region.id = static_cast<int>(regions.size());
    region.clean_area_cells = area;
    // Grid rows grow upwards, image rows downwards.
    region.bbox = {inner.x, child.height - (inner.y + inner.height), inner.width, inner.height};
    region.features = RegionFeatures(mask, child_roi, parent_roi, roi, context, r);
    // The cells to revert on repair: the raw difference near the region, so that the 1-cell walls the
    // clean-up shaved off the corridor's edges go too.
    cv::Mat near;
    cv::dilate(mask_inner, near, dilation_kernel);
    for (int row = 0; row < roi.height; ++row) {
      const std::uint8_t* near_row = near.ptr<std::uint8_t>(row);
      const std::uint8_t* raw_row = raw.ptr<std::uint8_t>(roi.y + row);
      for (int col = 0; col < roi.width; ++col) {
        if (near_row[col] && raw_row[roi.x + col]) {
          region.cells.push_back((roi.y + row) * child.width + roi.x + col);
        }
      }
    }
    regions.push_back(std::move(region));
  }
  return regions;
}

OccupancyGrid RepairChild(const OccupancyGrid& aligned_parent, const OccupancyGrid& child,
                          const std::vector<const ProtrusionRegion*>& protrusions, RepairMode mode) {
  if (mode == RepairMode::kFallBackToParent) return aligned_parent;
  OccupancyGrid repaired = child;
  for (const ProtrusionRegion* region : protrusions) {
    for (const std::int32_t cell : region->cells) {
      const auto index = static_cast<std::size_t>(cell);
      if (index < repaired.cells.size()) repaired.cells[index] = aligned_parent.cells[index];
    }
  }
  return repaired;
}

}  // namespace slamcore
