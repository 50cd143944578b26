// Comparison of a map-only version with its previous version (see map_comparison.h).
#include "analyzer/map_comparison.h"

#include "analyzer/telemetry_codec.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace analyzer {
namespace {

using slamcore::CellState;
using slamcore::InvalidArgument;
using slamcore::OccupancyGrid;
using slamcore::SE2;

/// Grid cells as an image with x = column and y = grid row (row 0 = lowest y, not flipped: rotations in this
/// image are rotations of the world), `on` where the cell is in `state`.
cv::Mat MaskOf(const OccupancyGrid& grid, CellState state) {
  cv::Mat mask(grid.height, grid.width, CV_8U, cv::Scalar(0));
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      if (grid.at(col, row) == static_cast<std::int8_t>(state)) mask.at<std::uint8_t>(row, col) = 255;
    }
  }
  return mask;
}

/// A wall image for ECC: exp(−d / `cells`) of the distance d to the nearest wall, so that walls that many cells
/// apart still correlate (the distance-transform softening ECC needs on thin binary structures). A wide one
/// for the search, a narrow one for the final refinement.
cv::Mat SoftWalls(const OccupancyGrid& grid, double cells) {
  cv::Mat not_wall;
  cv::bitwise_not(MaskOf(grid, CellState::kOccupied), not_wall);
  cv::Mat distance, soft;
  cv::distanceTransform(not_wall, distance, cv::DIST_L2, cv::DIST_MASK_5);
  cv::exp(distance * (-1.0 / cells), soft);
  return soft;  // CV_32F
}

/// The pixel (column, row) of a world point, continuous, cell centres at integers.
cv::Point2d PixelOf(const OccupancyGrid& grid, const slamcore::Vector2& world) {
  return {(world.x() - grid.origin_x) / grid.resolution - 0.5,
          (world.y() - grid.origin_y) / grid.resolution - 0.5};
}
slamcore::Vector2 WorldOf(const OccupancyGrid& grid, double col, double row) {
  return {grid.origin_x + (col + 0.5) * grid.resolution, grid.origin_y + (row + 0.5) * grid.resolution};
}

/// The 2×3 warp taking a pixel of `next` to the pixel of `previous` it shows (ECC's and warpAffine's
/// WARP_INVERSE_MAP convention), for a world transform new_T_previous.
cv::Mat WarpOf(const OccupancyGrid& previous, const OccupancyGrid& next, const SE2& new_T_previous) {
  const SE2 previous_T_new = new_T_previous.inverse();
  const slamcore::Matrix2 r = previous_T_new.rotation();
  // p_prev = R p_next + t: map the next pixel (0, 0) to get t.
  const cv::Point2d t = PixelOf(previous, previous_T_new * WorldOf(next, 0.0, 0.0));
  cv::Mat warp = (cv::Mat_<float>(2, 3) << r(0, 0), r(0, 1), t.x, r(1, 0), r(1, 1), t.y);
  return warp;
}

/// The inverse of WarpOf.
SE2 TransformOf(const OccupancyGrid& previous, const OccupancyGrid& next, const cv::Mat& warp) {
  const double theta = std::atan2(warp.at<float>(1, 0), warp.at<float>(0, 0));
  const slamcore::Vector2 origin_next = WorldOf(next, 0.0, 0.0);
  const slamcore::Vector2 origin_previous = WorldOf(previous, warp.at<float>(0, 2), warp.at<float>(1, 2));
  // previous_T_new maps origin_next to origin_previous with rotation θ.
  const SE2 rotation(0.0, 0.0, theta);
  const SE2 previous_T_new(origin_previous - rotation * origin_next, theta);
  return previous_T_new.inverse();
}

/// Refines `warp` in place by ECC; the correlation coefficient, or −1 when ECC did not converge.
double RefineByEcc(const cv::Mat& next_soft, const cv::Mat& previous_soft, cv::Mat& warp, int iterations) {
  try {
    return cv::findTransformECC(
        next_soft, previous_soft, warp, cv::MOTION_EUCLIDEAN,
        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, iterations, 1e-5), cv::noArray(),
        5);
  } catch (const cv::Exception&) {
    return -1.0;
  }
}

void MeasureQuality(const OccupancyGrid& previous, const OccupancyGrid& next,
                    const ComparisonOptions& options, MapAlignment* alignment) {
  cv::Mat not_wall;
  cv::bitwise_not(MaskOf(next, CellState::kOccupied), not_wall);
  cv::Mat distance;
  cv::distanceTransform(not_wall, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  std::int64_t walls = 0, hits = 0;
  double residual = 0.0;
  for (int row = 0; row < previous.height; ++row) {
    for (int col = 0; col < previous.width; ++col) {
      if (previous.at(col, row) != static_cast<std::int8_t>(CellState::kOccupied)) continue;
      ++walls;
      const cv::Point2d p = PixelOf(next, alignment->new_T_previous * WorldOf(previous, col, row));
      const int c = static_cast<int>(std::lround(p.x)), r = static_cast<int>(std::lround(p.y));
      if (!next.InBounds(c, r)) {
        residual += options.residual_cap_m;
        continue;
      }
      const double d = distance.at<float>(r, c) * next.resolution;
      hits += distance.at<float>(r, c) <= 1.5 ? 1 : 0;  // the 8 neighbours
      residual += std::min(d, options.residual_cap_m);
    }
  }
  alignment->previous_wall_cells = walls;
  alignment->wall_overlap = walls ? static_cast<double>(hits) / static_cast<double>(walls) : 0.0;
  alignment->residual_m = walls ? residual / static_cast<double>(walls) : 0.0;
  alignment->good = alignment->wall_overlap >= options.min_wall_overlap;
}

cv::Point2d WallCentroid(const OccupancyGrid& grid) {
  const cv::Moments moments = cv::moments(MaskOf(grid, CellState::kOccupied), true);
  return {moments.m10 / moments.m00, moments.m01 / moments.m00};
}

std::array<double, 4> WorldBox(const OccupancyGrid& grid, const slamcore::ImageBox& box) {
  // ImageBox rows count from the top of the image; grid rows from the bottom (OccupancyGrid::ImageRowOf).
  return {grid.origin_x + box.x * grid.resolution,
          grid.origin_y + (grid.height - box.y - box.height) * grid.resolution,
          grid.origin_x + (box.x + box.width) * grid.resolution,
          grid.origin_y + (grid.height - box.y) * grid.resolution};
}

std::string Box(const std::array<double, 4>& box) {
  char text[96];
  std::snprintf(text, sizeof(text), "[%.2f, %.2f]–[%.2f, %.2f] m", box[0], box[1], box[2], box[3]);
  return text;
}

}  // namespace

slamcore::Result<MapAlignment> AlignGrids(const OccupancyGrid& previous, const OccupancyGrid& next,
                                          const std::optional<SE2>& previous_dock,
                                          const std::optional<SE2>& next_dock,
                                          const ComparisonOptions& options) {
  if (previous.width <= 0 || previous.height <= 0) return InvalidArgument("previous map: empty grid");
  if (next.width <= 0 || next.height <= 0) return InvalidArgument("new map: empty grid");
  if (std::abs(previous.resolution - next.resolution) > 1e-9) {
    return InvalidArgument("resolution: the previous map has " + std::to_string(previous.resolution) +
                           " m, the new one " + std::to_string(next.resolution) + " m; they must be equal");
  }
  if (previous.CountCells(CellState::kOccupied) == 0)
    return InvalidArgument("previous map: no wall cell to align by");
  if (next.CountCells(CellState::kOccupied) == 0) return InvalidArgument("new map: no wall cell to align by");
  if (!(options.rotation_step_deg > 0.0)) return InvalidArgument("rotation_step_deg: must be positive");

  const cv::Mat previous_soft = SoftWalls(previous, 2.0), next_soft = SoftWalls(next, 2.0);
  const cv::Mat previous_wide = SoftWalls(previous, 10.0), next_wide = SoftWalls(next, 10.0);
  std::vector<MapAlignment> candidates;
  if (previous_dock && next_dock) {
    MapAlignment by_dock;
    by_dock.method = "dock";
    by_dock.new_T_previous = *next_dock * previous_dock->inverse();
    MeasureQuality(previous, next, options, &by_dock);
    candidates.push_back(by_dock);
    cv::Mat warp = WarpOf(previous, next, by_dock.new_T_previous);
    if (const double correlation = RefineByEcc(next_soft, previous_soft, warp, 100); correlation > 0.0) {
      MapAlignment refined;
      refined.method = "dock+registration";
      refined.correlation = correlation;
      refined.new_T_previous = TransformOf(previous, next, warp);
      MeasureQuality(previous, next, options, &refined);
      candidates.push_back(refined);
    }
  }
  // No dock, or a dock that does not align the walls (a moved or re-reported charger): registration alone.
  if (std::none_of(candidates.begin(), candidates.end(), [](const MapAlignment& a) { return a.good; })) {
    // Rotation search about the wall centroids, each start refined by a short ECC; the start whose walls land
    // best (wall overlap, the quality reported; ECC's own coefficient favours wrong poses that overlap large
    // free areas) is refined to convergence.
    const cv::Point2d previous_centre = WallCentroid(previous), next_centre = WallCentroid(next);
    cv::Mat best_warp;
    double best = -1.0, best_overlap = -1.0;
    std::vector<cv::Mat> starts{WarpOf(previous, next, SE2())};  // the two exports' own frames, as saved
    for (double degrees = 0.0; degrees < 360.0; degrees += options.rotation_step_deg) {
      const double theta = degrees * std::numbers::pi / 180.0, c = std::cos(theta), s = std::sin(theta);
      // p_prev = R (p_next − next_centre) + previous_centre
      starts.push_back((cv::Mat_<float>(2, 3) << c, -s,
                        previous_centre.x - (c * next_centre.x - s * next_centre.y), s, c,
                        previous_centre.y - (s * next_centre.x + c * next_centre.y)));
    }
    for (cv::Mat& warp : starts) {
      double correlation = RefineByEcc(next_wide, previous_wide, warp, 50);
      if (correlation > 0.0) correlation = RefineByEcc(next_soft, previous_soft, warp, 30);
      if (correlation <= 0.0) continue;
      MapAlignment start;
      start.new_T_previous = TransformOf(previous, next, warp);
      MeasureQuality(previous, next, options, &start);
      if (start.wall_overlap > best_overlap) {
        best_overlap = start.wall_overlap;
        best = correlation;
        best_warp = warp;
      }
    }
    if (best > 0.0) {
      const double correlation = RefineByEcc(next_soft, previous_soft, best_warp, 200);
      MapAlignment registered;
      registered.method = "registration";
      registered.correlation = correlation > 0.0 ? correlation : best;
      registered.new_T_previous = TransformOf(previous, next, best_warp);
      MeasureQuality(previous, next, options, &registered);
      candidates.push_back(registered);
    } else if (candidates.empty()) {
      MapAlignment identity;  // nothing converged: the maps' own frames, reported as such (and as poor)
      identity.method = "identity";
      MeasureQuality(previous, next, options, &identity);
      candidates.push_back(identity);
    }
  }
  return *std::max_element(
      candidates.begin(), candidates.end(),
      [](const MapAlignment& a, const MapAlignment& b) { return a.wall_overlap < b.wall_overlap; });
}

slamcore::Result<OccupancyGrid> ResampleOnto(const OccupancyGrid& previous, const OccupancyGrid& next,
                                             const SE2& new_T_previous) {
  if (std::abs(previous.resolution - next.resolution) > 1e-9)
    return InvalidArgument("resolution: must be equal");
  // Codes 0 unknown, 1 free, 2 occupied, so that the border (0) is unknown.
  cv::Mat codes(previous.height, previous.width, CV_8U);
  for (int row = 0; row < previous.height; ++row) {
    for (int col = 0; col < previous.width; ++col) {
      const std::int8_t cell = previous.at(col, row);
      codes.at<std::uint8_t>(row, col) = cell == static_cast<std::int8_t>(CellState::kFree)       ? 1
                                         : cell == static_cast<std::int8_t>(CellState::kOccupied) ? 2
                                                                                                  : 0;
    }
  }
  cv::Mat resampled;
  cv::warpAffine(codes, resampled, WarpOf(previous, next, new_T_previous), cv::Size(next.width, next.height),
                 cv::INTER_NEAREST | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT, cv::Scalar(0));
  OccupancyGrid aligned = next;
  for (int row = 0; row < next.height; ++row) {
    for (int col = 0; col < next.width; ++col) {
      const std::uint8_t code = resampled.at<std::uint8_t>(row, col);
      aligned.at(col, row) = static_cast<std::int8_t>(code == 1   ? CellState::kFree
                                                      : code == 2 ? CellState::kOccupied
                                                                  : CellState::kUnknown);
    }
  }
  return aligned;
}

slamcore::Result<MapComparison> CompareGrids(const OccupancyGrid& previous, const OccupancyGrid& next,
                                             const std::optional<SE2>& previous_dock,
                                             const std::optional<SE2>& next_dock,
                                             const slamcore::ProtrusionClassifier* classifier,
                                             const ComparisonOptions& options) {
  ASSIGN_OR_RETURN(auto alignment, AlignGrids(previous, next, previous_dock, next_dock, options));
  MapComparison comparison;
  comparison.alignment = alignment;
  ASSIGN_OR_RETURN(auto aligned, ResampleOnto(previous, next, alignment.new_T_previous));
  comparison.aligned_previous = std::move(aligned);
  const double cell_area = next.resolution * next.resolution;
  ASSIGN_OR_RETURN(auto found, slamcore::ExtractRegions(comparison.aligned_previous, next, options.detector));
  for (slamcore::ProtrusionRegion& region : found) {
    ChangedRegion& changed = comparison.new_regions.emplace_back();
    changed.world_bbox = WorldBox(next, region.bbox);
    changed.area_m2 = static_cast<double>(region.clean_area_cells) * cell_area;
    changed.predicted_class = "unclassified";
    if (classifier) {
      ASSIGN_OR_RETURN(auto probability, classifier->Probability(region.features));
      changed.probability = probability;
      changed.predicted_class = probability >= options.protrusion_probability ? "protrusion" : "new_space";
    }
    changed.region = std::move(region);
  }
  // Lost: the same detector with the roles swapped — cells the previous map knew that the new one does not.
  ASSIGN_OR_RETURN(auto lost, slamcore::ExtractRegions(next, comparison.aligned_previous, options.detector));
  for (slamcore::ProtrusionRegion& region : lost) {
    ChangedRegion& changed = comparison.lost_regions.emplace_back();
    changed.world_bbox = WorldBox(next, region.bbox);
    changed.area_m2 = static_cast<double>(region.clean_area_cells) * cell_area;
    changed.predicted_class = "lost";
    changed.region = std::move(region);
  }
  return comparison;
}

std::vector<fleet::v1::MapFinding> ComparisonFindings(const MapComparison& comparison,
                                                      std::int64_t previous_version) {
  std::vector<fleet::v1::MapFinding> findings;
  const MapAlignment& alignment = comparison.alignment;
  char text[256];
  {
    fleet::v1::MapFinding& finding = findings.emplace_back();
    finding.set_finding_kind(alignment.good ? fleet::v1::FINDING_KIND_ALIGNMENT
                                            : fleet::v1::FINDING_KIND_MISALIGNED);
    finding.set_severity(alignment.good ? 0.05 : 0.9);
    finding.set_finding_state(alignment.good ? fleet::v1::FINDING_STATE_INFO : fleet::v1::FINDING_STATE_OPEN);
    std::snprintf(text, sizeof(text),
                  "aligned with version %lld by %s: %.0f %% of its walls on walls, mean distance %.3f m, "
                  "shift (%.2f, %.2f) m, %.1f°",
                  static_cast<long long>(previous_version), alignment.method.c_str(),
                  100.0 * alignment.wall_overlap, alignment.residual_m, alignment.new_T_previous.x(),
                  alignment.new_T_previous.y(), alignment.new_T_previous.theta() * 180.0 / std::numbers::pi);
    finding.set_summary(text);
    finding.set_evidence_json(nlohmann::json{
        {"previous_version", previous_version},
        {"method", alignment.method},
        {"wall_overlap", alignment.wall_overlap},
        {"residual_m", alignment.residual_m},
        {"correlation", alignment.correlation},
        {"previous_wall_cells", alignment.previous_wall_cells},
        {"new_T_previous",
         {alignment.new_T_previous.x(), alignment.new_T_previous.y(), alignment.new_T_previous.theta()}}}
                                  .dump());
  }
  for (const bool lost : {false, true}) {
    for (const ChangedRegion& changed : lost ? comparison.lost_regions : comparison.new_regions) {
      fleet::v1::MapFinding& finding = findings.emplace_back();
      finding.set_finding_kind(lost ? fleet::v1::FINDING_KIND_LOST_REGION
                                    : fleet::v1::FINDING_KIND_NEW_REGION);
      const bool protrusion = changed.predicted_class == "protrusion";
      finding.set_severity(lost ? 0.6 : protrusion ? 0.5 + 0.3 * changed.probability : 0.2);
      finding.set_finding_state(lost || protrusion ? fleet::v1::FINDING_STATE_OPEN
                                                   : fleet::v1::FINDING_STATE_INFO);
      std::snprintf(text, sizeof(text), "%s region %d: %s%s, %.2f m² at %s", lost ? "lost" : "new",
                    changed.region.id, changed.predicted_class.c_str(),
                    changed.probability >= 0.0
                        ? (" (p " + std::to_string(changed.probability).substr(0, 4) + ")").c_str()
                        : "",
                    changed.area_m2, Box(changed.world_bbox).c_str());
      finding.set_summary(text);
      for (const double value : changed.world_bbox) finding.add_world_bbox(value);
      const slamcore::ImageBox& box = changed.region.bbox;
      finding.set_evidence_json(nlohmann::json{
          {"region_id", changed.region.id},
          {"class", changed.predicted_class},
          {"probability", changed.probability},
          {"area_m2", changed.area_m2},
          {"cells", changed.region.cells.size()},
          {"image_bbox", {box.x, box.y, box.width, box.height}},
          {"features", changed.region.features},
          {"previous_version",
           previous_version}}.dump());
    }
  }
  std::stable_sort(findings.begin(), findings.end(),
                   [](const fleet::v1::MapFinding& a, const fleet::v1::MapFinding& b) {
                     return a.severity() > b.severity();
                   });
  for (std::size_t i = 0; i < findings.size(); ++i)
    findings[i].set_finding_id(static_cast<std::int64_t>(i) + 1);
  return findings;
}

slamcore::Map MapOfGrid(const OccupancyGrid& grid) {
  slamcore::Map map;
  slamcore::Node node;
  node.id = 0;
  node.fixed = true;
  (void)map.graph.AddNode(node);  // the first node of an empty graph cannot be refused
  slamcore::LocalMapEvent patch;
  patch.resolution = grid.resolution;
  patch.width = grid.width;
  patch.height = grid.height;
  patch.node_T_origin = SE2(grid.origin_x, grid.origin_y, grid.origin_yaw);
  patch.cells = grid.cells;
  map.local_maps.emplace(node.id, std::move(patch));
  return map;
}

std::optional<SE2> DockOf(const fleet::v1::MapSnapshot& snapshot) {
  if (!snapshot.has_imported() || !snapshot.imported().has_dock()) return std::nullopt;
  const fleet::v1::Pose2& dock = snapshot.imported().dock();
  return SE2(dock.x(), dock.y(), dock.theta());
}

fleet::v1::MapSnapshot ImportedSnapshot(const slamcore::OccupancyGrid& grid, const std::string& format,
                                        const std::optional<slamcore::SE2>& dock,
                                        const std::optional<slamcore::SE2>& robot) {
  fleet::v1::MapSnapshot snapshot = ToProto(MapOfGrid(grid));
  fleet::v1::ImportedMapInfo* imported = snapshot.mutable_imported();
  imported->set_format(format);
  const auto pose = [](const slamcore::SE2& from, fleet::v1::Pose2* to) {
    to->set_x(from.x());
    to->set_y(from.y());
    to->set_theta(from.theta());
  };
  if (dock) pose(*dock, imported->mutable_dock());
  if (robot) pose(*robot, imported->mutable_robot());
  return snapshot;
}

fleet::v1::MapSnapshot ImportedSnapshot(const ValetudoMap& map) {
  const auto pose_of = [](const std::optional<ValetudoPose>& entity) {
    return entity ? std::optional<slamcore::SE2>(entity->pose) : std::nullopt;
  };
  return ImportedSnapshot(map.grid, "valetudo", pose_of(map.dock), pose_of(map.robot));
}

}  // namespace analyzer
