// The seeded generator of labelled protrusion / new-space pairs from real maps (physics in
// protrusion_data.h and docs/protrusion-data.md).
#include "slamcore/protrusion_data.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <deque>
#include <numbers>
#include <optional>
#include <random>

#include "range_scan.h"

namespace slamcore {
namespace {

constexpr std::int8_t kFree = static_cast<std::int8_t>(CellState::kFree);
constexpr std::int8_t kOccupied = static_cast<std::int8_t>(CellState::kOccupied);
constexpr std::int8_t kUnknown = static_cast<std::int8_t>(CellState::kUnknown);
constexpr int kAttempts = 80;

class Generator {
 public:
  Generator(const OccupancyGrid& base, std::uint64_t seed, const GeneratorOptions& options)
      : base_(base),
        options_(options),
        random_(seed),
        parent_(base),
        child_(base),
        truth_(base.cells.size(), 0),
        reserved_(base.height, base.width, CV_8U, cv::Scalar(0)) {
    cv::Mat free_mask(base.height, base.width, CV_8U);
    for (int row = 0; row < base.height; ++row) {
      for (int col = 0; col < base.width; ++col)
        free_mask.at<std::uint8_t>(row, col) = base.at(col, row) == kFree;
    }
    cv::distanceTransform(free_mask, clearance_, cv::DIST_L2, cv::DIST_MASK_5);  // cells to nearest non-free
    for (int row = 0; row < base.height; ++row) {
      for (int col = 0; col < base.width; ++col) {
        if (base.at(col, row) == kFree) free_cells_.push_back(Index(col, row));
        if (base.at(col, row) != kUnknown && HasNeighbour(col, row, kUnknown))
          edge_cells_.push_back(Index(col, row));
      }
    }
    // One robot model per pair: its sensor draws the stuck scans and reveals the new space. The corridor
    // family draws nothing here, so its pairs stay those of data set version 1.
    if (options_.scan_rendering || options_.stuck_robot_share > 0.0) {
      const auto& bands = options_.stuck.sensors;
      const auto& band = bands[static_cast<std::size_t>(Uniform(0, static_cast<int>(bands.size()) - 1))];
      sensor_.range_m = Uniform(band.range_m.low, band.range_m.high);
      sensor_.field_of_view = Uniform(band.field_of_view.low, band.field_of_view.high);
    }
  }

  Result<GeneratedPair> Run() {
    if (free_cells_.size() < 2000)
      return InvalidArgument("generator: the map has too little free space (< 5 m^2)");
    GeneratedPair pair;
    const int new_spaces = Uniform(options_.min_new_spaces, options_.max_new_spaces);
    for (int i = 0; i < new_spaces; ++i) pair.new_spaces += AddNewSpace();
    const int protrusions = Uniform(options_.min_protrusions, options_.max_protrusions);
    for (int i = 0; i < protrusions; ++i) pair.protrusions += AddProtrusion();
    AddSpeckle();
    Misregister();
    pair.child = std::move(child_);
    pair.truth = std::move(truth_);
    pair.parent = CropToKnown(parent_);
    return pair;
  }

 private:
  int Index(int col, int row) const { return row * base_.width + col; }
  int Uniform(int low, int high) {
    return std::uniform_int_distribution<int>(low, std::max(low, high))(random_);
  }
  double Uniform(double low, double high) {
    return std::uniform_real_distribution<double>(low, std::max(low, high))(random_);
  }
  double Uniform(const Interval& interval) { return Uniform(interval.low, interval.high); }
  bool Chance(double p) { return Uniform(0.0, 1.0) < p; }
  double Cells(double metres) const { return metres / base_.resolution; }

  bool HasNeighbour(int col, int row, std::int8_t value) const {
    for (const auto& [dc, dr] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      if (base_.InBounds(col + dc, row + dr) && base_.at(col + dc, row + dr) == value) return true;
    }
    return false;
  }
  bool Reserved(int index) const { return reserved_.data[index] != 0; }

  /// Keeps later changes ≥ 0.5 m away from this one, so that regions never merge and labels stay clean.
  void Reserve(const std::vector<int>& cells) {
    cv::Mat mask(reserved_.size(), CV_8U, cv::Scalar(0));
    for (const int cell : cells) mask.data[cell] = 1;
    const int radius = static_cast<int>(std::ceil(Cells(0.5)));
    cv::dilate(mask, mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * radius + 1, 2 * radius + 1}));
    reserved_ |= mask;
  }

  int RandomCell(const std::vector<int>& cells) {
    return cells[std::uniform_int_distribution<std::size_t>(0, cells.size() - 1)(random_)];
  }

  /// Drops a few edge cells of a change in the child: the sensor never sees every cell of a new area.
  void DropEdges(const std::vector<int>& cells, double probability) {
    for (const int cell : cells) {
      const int col = cell % base_.width, row = cell / base_.width;
      bool edge = false;
      for (const auto& [dc, dr] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        edge |= !base_.InBounds(col + dc, row + dr) ||
                truth_[static_cast<std::size_t>(Index(col + dc, row + dr))] == 0;
      }
      if (edge && Chance(probability)) {
        child_.cells[static_cast<std::size_t>(cell)] = parent_.cells[static_cast<std::size_t>(cell)];
        truth_[static_cast<std::size_t>(cell)] = 0;
      }
    }
  }

  int AddNewSpace() {
    for (int attempt = 0; attempt < kAttempts; ++attempt) {
      // The physical families add (d): the edge of known floor explored a little further.
      const int kind = Uniform(0, options_.scan_rendering ? 3 : 2);
      if (kind == 3 ? AddEdgeExploration() : kind == 2 ? AddMovedFurniture() : AddRoom(kind == 1)) return 1;
    }
    return 0;
  }

  /// (d): a strip along the edge of known floor (0.1–0.5 m deep, 0.5–3 m long) that the parent had not
  /// seen yet: a cleaning run that reached a little further along a wall or under a bed's edge. Real map
  /// pairs are full of these fringes.
  bool AddEdgeExploration() {
    if (edge_cells_.empty()) return false;
    const int start = RandomCell(edge_cells_);
    if (base_.cells[static_cast<std::size_t>(start)] != kFree || Reserved(start)) return false;
    const double depth = Cells(Uniform(0.1, 0.5)), length = Cells(Uniform(0.5, 3.0));
    // Floor within `length` of the start (geodesically, along the edge) and within `depth` of unknown.
    // The real map never changes, so its distance to unknown is computed once per pair, on first use.
    if (distance_to_unknown_.empty()) {
      cv::Mat known(base_.height, base_.width, CV_8U);
      for (std::size_t i = 0; i < base_.cells.size(); ++i)
        known.data[i] = base_.cells[i] == kUnknown ? 0 : 255;
      cv::distanceTransform(known, distance_to_unknown_, cv::DIST_L2, cv::DIST_MASK_5);
    }
    const cv::Mat& distance_to_unknown = distance_to_unknown_;
    std::vector<int> strip;
    std::vector<std::uint8_t> seen(base_.cells.size(), 0);
    std::deque<std::pair<int, int>> queue{{start, 0}};
    seen[static_cast<std::size_t>(start)] = 1;
    while (!queue.empty()) {
      const auto [cell, steps] = queue.front();
      queue.pop_front();
      strip.push_back(cell);
      if (steps >= length) continue;
      const int col = cell % base_.width, row = cell / base_.width;
      for (const auto& [dc, dr] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        if (!base_.InBounds(col + dc, row + dr)) continue;
        const int next = Index(col + dc, row + dr);
        if (seen[static_cast<std::size_t>(next)] || base_.cells[static_cast<std::size_t>(next)] != kFree ||
            distance_to_unknown.at<float>(row + dr, col + dc) > depth || Reserved(next)) {
          continue;
        }
        seen[static_cast<std::size_t>(next)] = 1;
        queue.push_back({next, steps + 1});
      }
    }
    if (static_cast<double>(strip.size()) < 0.1 / (base_.resolution * base_.resolution)) return false;
    for (const int cell : strip) {
      parent_.cells[static_cast<std::size_t>(cell)] = kUnknown;
      truth_[static_cast<std::size_t>(cell)] = static_cast<std::uint8_t>(TruthLabel::kNewSpace);
    }
    DropEdges(strip, 0.2);
    Reserve(strip);
    return true;
  }

  /// (a)/(b): a room seen for the first time, or behind a door that was closed in the parent.
  bool AddRoom(bool door) {
    const int seed = RandomCell(free_cells_);
    if (clearance_.at<float>(seed / base_.width, seed % base_.width) < Cells(0.4) || Reserved(seed))
      return false;
    const double radius = Cells(Uniform(1.0, 3.5));
    std::vector<int> distance(base_.cells.size(), -1);
    std::vector<int> room{seed};
    std::deque<int> queue{seed};
    distance[static_cast<std::size_t>(seed)] = 0;
    // The physical families take whole rooms (the seed's room, bounded by walls and doorways); the corridor
    // family takes geodesic balls, as in data set version 1.
    if (options_.scan_rendering && !SeedRoom(seed, &room, &distance)) return false;
    if (options_.scan_rendering) queue.clear();
    while (!queue.empty()) {
      const int cell = queue.front();
      queue.pop_front();
      if (distance[static_cast<std::size_t>(cell)] >= radius) continue;
      const int col = cell % base_.width, row = cell / base_.width;
      for (const auto& [dc, dr] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        if (!base_.InBounds(col + dc, row + dr)) continue;
        const int next = Index(col + dc, row + dr);
        if (distance[static_cast<std::size_t>(next)] >= 0 ||
            base_.cells[static_cast<std::size_t>(next)] != kFree || Reserved(next)) {
          continue;
        }
        distance[static_cast<std::size_t>(next)] = distance[static_cast<std::size_t>(cell)] + 1;
        room.push_back(next);
        queue.push_back(next);
      }
    }
    const double area = static_cast<double>(room.size()) * base_.resolution * base_.resolution;
    if (area < 1.0 || room.size() > free_cells_.size() * 2 / 5) return false;
    // Walls that belong to the room only, and the cut between the room and the rest of the free space.
    std::vector<int> walls, cut;
    for (const int cell : room) {
      const int col = cell % base_.width, row = cell / base_.width;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          if (!base_.InBounds(col + dc, row + dr)) continue;
          const int next = Index(col + dc, row + dr);
          const std::int8_t value = base_.cells[static_cast<std::size_t>(next)];
          if (distance[static_cast<std::size_t>(next)] >= 0) continue;
          if (value == kOccupied && !TouchesOutsideFree(next, distance)) walls.push_back(next);
          if (value == kFree && (dr == 0 || dc == 0)) cut.push_back(next);
        }
      }
    }
    std::sort(walls.begin(), walls.end());
    walls.erase(std::unique(walls.begin(), walls.end()), walls.end());
    std::sort(cut.begin(), cut.end());
    cut.erase(std::unique(cut.begin(), cut.end()), cut.end());
    for (const int cell : cut) {
      if (Reserved(cell)) return false;
    }
    std::vector<int> changed = room;
    changed.insert(changed.end(), walls.begin(), walls.end());
    for (const int cell : changed) parent_.cells[static_cast<std::size_t>(cell)] = kUnknown;
    if (door && static_cast<double>(cut.size()) * base_.resolution <= 1.5) {
      for (const int cell : cut)
        parent_.cells[static_cast<std::size_t>(cell)] = kOccupied;  // the closed door
      changed.insert(changed.end(), cut.begin(), cut.end());
    }
    // Half the scanned families' rooms come from the real map as its robot drew them (clutter and all).
    if (options_.scan_rendering && Chance(0.5)) return RevealByScans(room, cut, changed);
    for (const int cell : changed)
      truth_[static_cast<std::size_t>(cell)] = static_cast<std::uint8_t>(TruthLabel::kNewSpace);
    DropEdges(changed, 0.1);
    Reserve(changed);
    return true;
  }

  /// The room around `seed`: floor that stays connected when every passage narrower than a doorway
  /// (0.9 m) is closed, grown back to the walls. Fails for a room with reserved cells.
  bool SeedRoom(int seed, std::vector<int>* room, std::vector<int>* distance) {
    if (room_labels_.empty()) {
      cv::Mat wide = clearance_ >= Cells(0.45);
      wide.convertTo(wide, CV_8U);
      cv::connectedComponents(wide, room_labels_, 4, CV_32S);
    }
    const int label = room_labels_.at<int>(seed / base_.width, seed % base_.width);
    if (label <= 0) return false;
    cv::Mat core = room_labels_ == label, grown;
    const int reach = static_cast<int>(std::ceil(Cells(0.45))) + 1;
    cv::dilate(core, grown, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * reach + 1, 2 * reach + 1}));
    room->clear();
    for (const int cell : free_cells_) {
      if (!grown.data[cell]) continue;
      if (Reserved(cell)) return false;
      room->push_back(cell);
      (*distance)[static_cast<std::size_t>(cell)] = 0;
    }
    return true;
  }

  /// The room (with its walls and door) the parent lacks, seen by the pair's sensor: from a few places
  /// inside it (the robot drove in), or once from outside through its doorway (a glimpse, a lidar's fan).
  bool RevealByScans(const std::vector<int>& room, const std::vector<int>& cut,
                     const std::vector<int>& hidden) {
    for (const int cell : hidden)
      child_.cells[static_cast<std::size_t>(cell)] = parent_.cells[static_cast<std::size_t>(cell)];
    internal::ScanVotes votes(base_);
    const double radius = Cells(options_.stuck.robot_radius_m);
    std::vector<int> in_room, sorted_room(room);
    std::sort(sorted_room.begin(), sorted_room.end());
    for (const int cell : room) {
      if (clearance_.at<float>(cell / base_.width, cell % base_.width) >= radius) in_room.push_back(cell);
    }
    if (!cut.empty() && Chance(0.3)) {
      // From outside: a spot up to 3 m from the doorway with the doorway in view.
      const int door = RandomCell(cut);
      for (int attempt = 0; attempt < kAttempts; ++attempt) {
        const int spot = RandomCell(free_cells_);
        const double dx = door % base_.width - spot % base_.width,
                     dy = door / base_.width - spot / base_.width;
        const double distance = std::hypot(dx, dy);
        if (distance < Cells(0.4) || distance > Cells(std::min(3.0, sensor_.range_m)) ||
            clearance_.at<float>(spot / base_.width, spot % base_.width) < radius ||
            std::binary_search(sorted_room.begin(), sorted_room.end(), spot) || Reserved(spot)) {
          continue;
        }
        votes.AddScan(base_, CellPose(spot, std::atan2(dy, dx)), CellPose(spot, std::atan2(dy, dx)), sensor_,
                      false, random_);
        break;
      }
    } else if (!in_room.empty()) {
      const int scans = Uniform(2, 6);
      for (int i = 0; i < scans; ++i) {
        const SE2 pose = CellPose(RandomCell(in_room), Uniform(-std::numbers::pi, std::numbers::pi));
        votes.AddScan(base_, pose, pose, sensor_, false, random_);
      }
    }
    return ApplyVotes(votes, Cells(1.0) * Cells(1.0)) > 0;
  }

  /// A world pose at a cell's centre.
  SE2 CellPose(int cell, double heading) const {
    return SE2(base_.origin_x + (cell % base_.width + 0.5) * base_.resolution,
               base_.origin_y + (cell / base_.width + 0.5) * base_.resolution, heading);
  }

  /// Fuses scans into the child as a robot's renderer would, over what the parent knew: unknown cells
  /// take the votes' state, a wall gives way only to a clear majority of free votes, and known floor
  /// turns to wall only under a clear majority of hits. Changed cells are labelled by what made them
  /// (erroneous poses: protrusion). Reserved cells (other changes) are left alone. Keeps the change when
  /// it has at least `min_cells` changed cells; otherwise undoes it and returns 0.
  int ApplyVotes(const internal::ScanVotes& votes, double min_cells) {
    std::vector<int> changed;
    for (std::size_t cell = 0; cell < child_.cells.size(); ++cell) {
      if (!votes.Voted(cell) || Reserved(static_cast<int>(cell))) continue;
      const std::int8_t before = parent_.cells[cell];
      const int free = votes.Free(cell), occupied = votes.Occupied(cell);
      std::int8_t after = before;
      if (before == kUnknown) {
        after = votes.Resolve(cell);
      } else if (before == kOccupied && free >= 3 * (occupied + 1)) {
        after = kFree;
      } else if (before == kFree && occupied >= 3 && 2 * free < occupied) {
        after = kOccupied;
      }
      if (after == child_.cells[cell]) continue;
      child_.cells[cell] = after;
      changed.push_back(static_cast<int>(cell));
    }
    long counted = 0;
    for (const int cell : changed) {
      const auto index = static_cast<std::size_t>(cell);
      const bool is_new = (parent_.cells[index] == kUnknown) ||
                          (child_.cells[index] == kFree && parent_.cells[index] == kOccupied);
      if (!is_new) continue;  // a wall drawn over known floor: no difference the detector could see
      truth_[index] = static_cast<std::uint8_t>(votes.MostlyErroneous(index) ? TruthLabel::kProtrusion
                                                                             : TruthLabel::kNewSpace);
      ++counted;
    }
    if (static_cast<double>(counted) < min_cells) {
      for (const int cell : changed) {
        child_.cells[static_cast<std::size_t>(cell)] = parent_.cells[static_cast<std::size_t>(cell)];
        truth_[static_cast<std::size_t>(cell)] = 0;
      }
      return 0;
    }
    Reserve(changed);
    return static_cast<int>(counted);
  }

  bool TouchesOutsideFree(int cell, const std::vector<int>& distance) const {
    const int col = cell % base_.width, row = cell / base_.width;
    for (int dr = -1; dr <= 1; ++dr) {
      for (int dc = -1; dc <= 1; ++dc) {
        if (!base_.InBounds(col + dc, row + dr)) continue;
        const int next = Index(col + dc, row + dr);
        if (base_.cells[static_cast<std::size_t>(next)] == kFree &&
            distance[static_cast<std::size_t>(next)] < 0) {
          return true;
        }
      }
    }
    return false;
  }

  /// (c): a sofa or bed moved away: the parent saw its outline (unknown inside), the child sees floor.
  bool AddMovedFurniture() {
    const int centre = RandomCell(free_cells_);
    // Half are small (a chair, a box, a bin: 0.3–0.6 m), half large (a sofa or bed: 0.6–1.6 × 1.2–2.4 m).
    const bool small = Chance(0.5);
    const double width = Cells(small ? Uniform(0.3, 0.6) : Uniform(0.6, 1.6));
    const double length = Cells(small ? Uniform(0.3, 0.8) : Uniform(1.2, 2.4));
    const double angle = Uniform(0.0, std::numbers::pi);
    const double c = std::cos(angle), s = std::sin(angle);
    const int reach = static_cast<int>(std::ceil(0.5 * std::hypot(width, length))) + 1;
    const int centre_col = centre % base_.width, centre_row = centre / base_.width;
    std::vector<int> cells;
    std::vector<bool> outline;
    for (int dr = -reach; dr <= reach; ++dr) {
      for (int dc = -reach; dc <= reach; ++dc) {
        const double u = c * dc + s * dr, v = -s * dc + c * dr;
        if (std::abs(u) > 0.5 * length || std::abs(v) > 0.5 * width) continue;
        const int col = centre_col + dc, row = centre_row + dr;
        if (!base_.InBounds(col, row)) return false;
        const int index = Index(col, row);
        if (base_.cells[static_cast<std::size_t>(index)] != kFree || Reserved(index)) return false;
        cells.push_back(index);
        outline.push_back(std::abs(u) > 0.5 * length - 1.0 || std::abs(v) > 0.5 * width - 1.0);
      }
    }
    for (std::size_t i = 0; i < cells.size(); ++i) {
      parent_.cells[static_cast<std::size_t>(cells[i])] = outline[i] ? kOccupied : kUnknown;
      truth_[static_cast<std::size_t>(cells[i])] = static_cast<std::uint8_t>(TruthLabel::kNewSpace);
    }
    Reserve(cells);
    return true;
  }

  int AddProtrusion() {
    const bool stuck = options_.stuck_robot_share > 0.0 && Chance(options_.stuck_robot_share);
    for (int attempt = 0; attempt < kAttempts; ++attempt) {
      if (stuck ? TryStuckRobot() : TryProtrusion()) return 1;
    }
    return 0;
  }

  /// A robot stuck with its wheels turning (see the header): pressed against an obstacle, or lifted on a
  /// rug in open floor; one scan per node of the believed path, all cast from the true place.
  bool TryStuckRobot() {
    const StuckRobotPhysics& physics = options_.stuck;
    const int cell = RandomCell(free_cells_);
    if (Reserved(cell)) return false;
    const double radius = Cells(physics.robot_radius_m);
    const double clearance = clearance_.at<float>(cell / base_.width, cell % base_.width);
    double push = Uniform(-std::numbers::pi, std::numbers::pi);
    if (Chance(physics.contact_share)) {
      if (clearance < radius || clearance > radius + Cells(0.05)) return false;
      // The obstacle's normal: the direction of the nearest wall cell around the robot.
      const auto normal = NearestWallDirection(cell, radius + Cells(0.10));
      if (!normal) return false;
      push = *normal + (Chance(0.5) ? 1.0 : -1.0) * Uniform(physics.push_deviation);
    } else if (clearance < radius + Cells(0.05)) {
      return false;
    }
    const SE2 true_pose = CellPose(cell, push);
    const double travel = Uniform(physics.stuck_travel_m);
    const double drift = Uniform(-physics.max_heading_drift_per_m, physics.max_heading_drift_per_m);
    internal::ScanVotes votes(base_);
    std::normal_distribution<double> rock(0.0, 1.0);
    SE2 believed = true_pose;
    for (double odometry = 0.0; odometry <= travel; odometry += physics.keyframe_m) {
      // The robot rocks a little in place while its wheels turn.
      const SE2 seen_from = true_pose * SE2(0.01 * rock(random_), 0.01 * rock(random_), 0.02 * rock(random_));
      votes.AddScan(base_, seen_from, believed, sensor_, odometry > 0.0, random_);
      believed = believed * SE2(physics.keyframe_m, 0.0, physics.keyframe_m * drift);
    }
    return ApplyVotes(votes, std::max(20.0, 0.1 / (base_.resolution * base_.resolution))) > 0;
  }

  /// The direction (radians) from a cell to the nearest occupied cell within `reach` cells, if any.
  std::optional<double> NearestWallDirection(int cell, double reach) const {
    const int col = cell % base_.width, row = cell / base_.width, span = static_cast<int>(std::ceil(reach));
    double best = reach * reach + 1.0;
    std::optional<double> direction;
    for (int dr = -span; dr <= span; ++dr) {
      for (int dc = -span; dc <= span; ++dc) {
        const double d2 = dc * dc + dr * dr;
        if (d2 >= best || !base_.InBounds(col + dc, row + dr) || base_.at(col + dc, row + dr) != kOccupied)
          continue;
        best = d2;
        direction = std::atan2(static_cast<double>(dr), static_cast<double>(dc));
      }
    }
    return direction;
  }

  /// A slip corridor: the false path the odometry integrated while the wheels spun (see the header).
  bool TryProtrusion() {
    const int start = RandomCell(free_cells_);
    if (clearance_.at<float>(start / base_.width, start % base_.width) < Cells(0.15) || Reserved(start))
      return false;
    double x = start % base_.width + 0.5, y = start / base_.width + 0.5;
    double heading = Uniform(-std::numbers::pi, std::numbers::pi);
    const double curvature = Uniform(-0.12, 0.12) * base_.resolution;  // per cell, gently curved
    const double robot_width = Cells(Uniform(options_.min_robot_width_m, options_.max_robot_width_m));
    const double wobble = Cells(0.015), wavelength = Cells(Uniform(1.0, 2.0)), phase = Uniform(0.0, 6.28);
    const double outside_length =
        Cells(Uniform(options_.min_protrusion_length_m, options_.max_protrusion_length_m));
    const int edge_thickness = Chance(0.7) ? 1 : 2;
    const double step = 0.25;
    double travelled = 0.0, outside = 0.0;
    bool left_known = false;
    struct Point {
      double x, y, half_width;
    };
    std::vector<Point> path;
    while (outside < outside_length) {
      const int col = static_cast<int>(std::floor(x)), row = static_cast<int>(std::floor(y));
      if (!base_.InBounds(col, row)) return false;
      const int index = Index(col, row);
      const std::int8_t value = base_.cells[static_cast<std::size_t>(index)];
      if (value != kFree) left_known = true;
      if (left_known) {
        if (value == kFree || Reserved(index)) return false;  // must end in unknown space, not another room
        outside += step;
      } else if (travelled > Cells(2.0)) {
        return false;  // the robot was not near the edge of known space
      }
      path.push_back({x, y, 0.5 * robot_width + wobble * std::sin(travelled / wavelength * 6.2832 + phase)});
      x += step * std::cos(heading);
      y += step * std::sin(heading);
      heading += curvature * step;
      travelled += step;
    }
    // Rasterise: corridor cells free, a 1–2-cell rim of smeared wall hits where the map knew nothing.
    std::vector<int> corridor, rim;
    std::vector<std::uint8_t> mark(base_.cells.size(), 0);
    for (const Point& point : path) {
      const double outer = point.half_width + edge_thickness;
      const int reach = static_cast<int>(std::ceil(outer)) + 1;
      for (int dr = -reach; dr <= reach; ++dr) {
        for (int dc = -reach; dc <= reach; ++dc) {
          const int col = static_cast<int>(std::floor(point.x)) + dc,
                    row = static_cast<int>(std::floor(point.y)) + dr;
          if (!base_.InBounds(col, row)) return false;
          const double distance = std::hypot(col + 0.5 - point.x, row + 0.5 - point.y);
          const int index = Index(col, row);
          std::uint8_t& m = mark[static_cast<std::size_t>(index)];
          if (distance <= point.half_width && m != 1) {
            corridor.push_back(index);  // also when an earlier point had marked it as rim
            m = 1;
          } else if (distance <= outer && m == 0) {
            m = 2;
            rim.push_back(index);
          }
        }
      }
    }
    std::vector<int> changed;
    for (const int cell : corridor) {
      if (mark[static_cast<std::size_t>(cell)] == 1 && base_.cells[static_cast<std::size_t>(cell)] != kFree) {
        if (Reserved(cell)) return false;
        changed.push_back(cell);
      }
    }
    for (const int cell : rim) {
      if (mark[static_cast<std::size_t>(cell)] == 2 &&
          base_.cells[static_cast<std::size_t>(cell)] == kUnknown) {
        if (Reserved(cell)) return false;
        if (Chance(0.85)) changed.push_back(cell);  // some hits never land: gaps in the rim
      }
    }
    if (static_cast<double>(changed.size()) < 0.5 * Cells(options_.min_protrusion_length_m) * robot_width)
      return false;
    for (const int cell : changed) {
      child_.cells[static_cast<std::size_t>(cell)] =
          mark[static_cast<std::size_t>(cell)] == 1 ? kFree : kOccupied;
      truth_[static_cast<std::size_t>(cell)] = static_cast<std::uint8_t>(TruthLabel::kProtrusion);
    }
    Reserve(changed);
    return true;
  }

  /// The child's registration error: the child and its truth moved by a small rigid transform about the
  /// grid's centre, nearest cell, so that walls land a cell or two off (and re-rendering drops or doubles
  /// a few wall cells) as they do between two real mapping sessions. Cells moved in from outside the grid
  /// are unknown and unchanged.
  void Misregister() {
    const Interval& shift = options_.registration_shift_m;
    const Interval& rotation = options_.registration_rotation;
    if (shift.high <= 0.0 && rotation.high <= 0.0)
      return;  // no random draw: version 1 pairs stay as they were
    const double length = Uniform(shift.low, shift.high) / base_.resolution;  // cells
    const double direction = Uniform(-std::numbers::pi, std::numbers::pi);
    const double angle = Uniform(rotation.low, rotation.high) * (Uniform(0, 1) == 0 ? -1.0 : 1.0);
    const double centre_col = 0.5 * (base_.width - 1), centre_row = 0.5 * (base_.height - 1);
    const double c = std::cos(angle), s = std::sin(angle);
    const double shift_col = length * std::cos(direction), shift_row = length * std::sin(direction);
    OccupancyGrid moved = child_;
    std::vector<std::uint8_t> moved_truth(truth_.size(), 0);
    for (int row = 0; row < base_.height; ++row) {
      for (int col = 0; col < base_.width; ++col) {
        // The source cell: the inverse of (rotate about the centre, then shift).
        const double u = col - centre_col - shift_col, v = row - centre_row - shift_row;
        const int source_col = static_cast<int>(std::lround(centre_col + c * u + s * v));
        const int source_row = static_cast<int>(std::lround(centre_row - s * u + c * v));
        const bool inside =
            source_col >= 0 && source_col < base_.width && source_row >= 0 && source_row < base_.height;
        moved.at(col, row) = inside ? child_.at(source_col, source_row) : kUnknown;
        moved_truth[static_cast<std::size_t>(Index(col, row))] =
            inside ? truth_[static_cast<std::size_t>(Index(source_col, source_row))] : 0;
      }
    }
    child_ = std::move(moved);
    truth_ = std::move(moved_truth);
  }

  /// Sensor speckle and re-scan fringes along known edges: differences the clean-up must remove.
  void AddSpeckle() {
    if (edge_cells_.empty()) return;
    const int speckles = Uniform(0, options_.max_speckles);
    for (int i = 0; i < speckles; ++i) {
      const int cell = RandomCell(edge_cells_);
      const int size = Uniform(1, 2);
      const std::int8_t value = Chance(0.5) ? kFree : kOccupied;
      for (int dr = 0; dr < size; ++dr) {
        for (int dc = 0; dc < size; ++dc) Speck(cell % base_.width + dc, cell / base_.width + dr, value);
      }
    }
    const int fringes = Uniform(0, 3);
    for (int i = 0; i < fringes; ++i) {
      const int cell = RandomCell(edge_cells_);
      const bool along_x = Chance(0.5);
      const int length = Uniform(5, 20);
      for (int k = 0; k < length; ++k) {
        Speck(cell % base_.width + (along_x ? k : 0), cell / base_.width + (along_x ? 0 : k), kFree);
      }
    }
  }

  void Speck(int col, int row, std::int8_t value) {
    if (!base_.InBounds(col, row)) return;
    const auto index = static_cast<std::size_t>(Index(col, row));
    if (Reserved(static_cast<int>(index)) || child_.cells[index] != kUnknown ||
        parent_.cells[index] != kUnknown)
      return;
    child_.cells[index] = value;
  }

  /// The parent as a robot would have saved it: cropped to its known cells plus a margin.
  static OccupancyGrid CropToKnown(const OccupancyGrid& grid) {
    int min_col = grid.width, min_row = grid.height, max_col = -1, max_row = -1;
    for (int row = 0; row < grid.height; ++row) {
      for (int col = 0; col < grid.width; ++col) {
        if (grid.at(col, row) == kUnknown) continue;
        min_col = std::min(min_col, col);
        max_col = std::max(max_col, col);
        min_row = std::min(min_row, row);
        max_row = std::max(max_row, row);
      }
    }
    const int margin = 10;
    min_col = std::max(0, min_col - margin);
    min_row = std::max(0, min_row - margin);
    max_col = std::min(grid.width - 1, max_col + margin);
    max_row = std::min(grid.height - 1, max_row + margin);
    OccupancyGrid cropped = *OccupancyGrid::Create(max_col - min_col + 1, max_row - min_row + 1,
                                                   grid.resolution, grid.origin_x + min_col * grid.resolution,
                                                   grid.origin_y + min_row * grid.resolution);
    for (int row = 0; row < cropped.height; ++row) {
      for (int col = 0; col < cropped.width; ++col)
        cropped.at(col, row) = grid.at(col + min_col, row + min_row);
    }
    return cropped;
  }

  const OccupancyGrid& base_;
  GeneratorOptions options_;
  std::mt19937_64 random_;
  OccupancyGrid parent_, child_;
  std::vector<std::uint8_t> truth_;
  cv::Mat reserved_;
  cv::Mat clearance_;
  std::vector<int> free_cells_, edge_cells_;
  internal::RangeSensor sensor_;
  cv::Mat room_labels_;  // rooms for the physical families' new space (SeedRoom), computed on first use
  cv::Mat
      distance_to_unknown_;  // cells from each cell to the real map's unknown (AddEdgeExploration), likewise
};

}  // namespace

Result<GeneratedPair> GeneratePair(const OccupancyGrid& real_map, std::uint64_t seed,
                                   const GeneratorOptions& options) {
  if (real_map.width <= 0 || real_map.height <= 0 ||
      real_map.cells.size() != static_cast<std::size_t>(real_map.width) * real_map.height) {
    return InvalidArgument("generator: the real map is empty or malformed");
  }
  if (options.min_protrusions < 0 || options.max_protrusions > 20 || options.min_new_spaces < 0 ||
      options.max_new_spaces > 20 || !(options.min_robot_width_m > 0.0) ||
      options.max_robot_width_m < options.min_robot_width_m || !(options.min_protrusion_length_m > 0.0) ||
      options.max_protrusion_length_m < options.min_protrusion_length_m ||
      options.max_protrusion_length_m > 20.0) {
    return InvalidArgument("generator: options out of range");
  }
  if (options.stuck_robot_share < 0.0 || options.stuck_robot_share > 1.0 || options.stuck.sensors.empty() ||
      options.stuck.sensors.size() > 16 || !(options.stuck.keyframe_m >= 0.05) ||
      !(options.stuck.robot_radius_m > 0.0) || options.stuck.robot_radius_m > 1.0 ||
      !(options.stuck.stuck_travel_m.low >= 0.0) || !(options.stuck.stuck_travel_m.high <= 20.0) ||
      !(std::abs(options.stuck.max_heading_drift_per_m) <= 2.0)) {
    return InvalidArgument("generator: stuck-robot physics out of range");
  }
  const auto within = [](const Interval& interval, double most) {
    return interval.low >= 0.0 && interval.high >= interval.low && interval.high <= most;
  };
  if (!within(options.registration_shift_m, 1.0) || !within(options.registration_rotation, 0.2)) {
    return InvalidArgument("generator: registration error out of range (shift 0..1 m, rotation 0..0.2 rad)");
  }
  double longest_reach = options.max_protrusion_length_m;
  for (const auto& band : options.stuck.sensors) {
    if (!(band.range_m.low > 0.0) || !(band.range_m.high <= 20.0) || !(band.field_of_view.low > 0.0)) {
      return InvalidArgument("generator: sensor ranges must lie in (0, 20] m and fields of view be positive");
    }
    if (options.stuck_robot_share > 0.0)
      longest_reach = std::max(longest_reach, options.stuck.stuck_travel_m.high + band.range_m.high);
  }
  // The pairs are for the detector, which takes maps of 1 mm per cell or coarser; a resolution below
  // that is almost always one written in the wrong unit, and would make the padding below overflow.
  if (!(real_map.resolution >= kMinDetectorResolutionM)) {
    return InvalidArgument("generator: the real map's resolution, " + MessageNumber(real_map.resolution) +
                           " m per cell, is finer than the protrusion detector's " +
                           MessageNumber(kMinDetectorResolutionM) + " m; check its unit (metres per cell)");
  }
  // Pad by the farthest reach so that a slip out of the map's edge stays inside the child's image.
  const double pad_cells = std::ceil((longest_reach + 1.0) / real_map.resolution);
  if (real_map.width + 2.0 * pad_cells > kMaxGridSide || real_map.height + 2.0 * pad_cells > kMaxGridSide ||
      (real_map.width + 2.0 * pad_cells) * (real_map.height + 2.0 * pad_cells) > kMaxGridCells) {
    return InvalidArgument(
        "generator: the real map (" + std::to_string(real_map.width) + " x " +
        std::to_string(real_map.height) + " cells of " + MessageNumber(real_map.resolution) +
        " m) with the " + MessageNumber(longest_reach + 1.0) +
        " m a stuck robot may reach beyond each edge is larger than a map may be (" +
        std::to_string(kMaxGridSide) + " cells a side, " + std::to_string(kMaxGridCells) + " in all)");
  }
  const int pad = static_cast<int>(pad_cells);
  ASSIGN_OR_RETURN(auto base,
                   OccupancyGrid::Create(real_map.width + 2 * pad, real_map.height + 2 * pad,
                                         real_map.resolution, real_map.origin_x - pad * real_map.resolution,
                                         real_map.origin_y - pad * real_map.resolution));
  base.origin_yaw = real_map.origin_yaw;
  for (int row = 0; row < real_map.height; ++row) {
    for (int col = 0; col < real_map.width; ++col) base.at(col + pad, row + pad) = real_map.at(col, row);
  }
  return Generator(base, seed, options).Run();
}

Result<GeneratorOptions> GeneratorFamily(const std::string& name) {
  GeneratorOptions options;
  if (name == "corridor") return options;
  options.scan_rendering = true;
  options.min_protrusions = 1;
  if (name == "physical") {
    options.stuck_robot_share = 0.8;
    return options;
  }
  if (name == "heldout" || name == "misregistered") {
    options.stuck_robot_share = 1.0;
    StuckRobotPhysics& physics = options.stuck;
    // Sensor ranges, fields of view and push angles disjoint from "physical"'s: other robot models,
    // other pushes; travel and drift reach beyond its.
    physics.sensors = {{{1.6, 4.0}, {2.2, 3.6}}, {{6.0, 8.0}, {6.3, 6.3}}};
    physics.push_deviation = {0.52, 1.31};
    physics.stuck_travel_m = {1.0, 6.0};
    physics.max_heading_drift_per_m = 0.30;
    physics.contact_share = 0.9;
    // "misregistered": the same pairs with the child drawn one or two cells off the parent, as a later
    // export aligned by dock and image registration is (a test of the detector's registration tolerance).
    if (name == "misregistered") {
      options.registration_shift_m = {0.05, 0.10};
      options.registration_rotation = {0.0, 0.002};  // up to 0.11°: 1 cm at 5 m from the home's centre
    }
    return options;
  }
  return InvalidArgument("unknown generator family \"" + name +
                         "\" (corridor, physical, heldout, misregistered)");
}

}  // namespace slamcore
