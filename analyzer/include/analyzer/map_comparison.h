// Comparison of a map-only version (an imported Valetudo or map_server map) with its previous version
// (docs/formats/map-versions.md "Imported maps", "Comparison"): the two occupancy grids are aligned, the
// alignment's quality is measured, and the difference is split into connected regions — new ones, described
// and classed by slamcore's protrusion detector and classifier (paper IV-C, as runs are), and lost ones.
//
//  * Alignment: by the dock poses when both maps have one (new_T_previous = new_dock · previous_dock⁻¹), refined
//    by image registration; else, or when that leaves the walls apart (a moved charger), by registration alone: OpenCV's ECC (Evangelidis & Psarakis, "Parametric
//    image alignment using enhanced correlation coefficient maximization", PAMI 2008; cv::findTransformECC,
//    MOTION_EUCLIDEAN) on wall images softened by a distance transform, started from a rotation search about
//    the walls' centroids. Quality: the fraction of the previous map's wall cells that land within one cell
//    of a new wall, and their mean distance to the nearest new wall.
//  * Difference: the previous grid resampled onto the new grid's cells (nearest neighbour), then
//    slamcore::ExtractRegions both ways: new regions (known now, unknown before, or a wall opened) and lost
//    regions (known before, unknown now).
//
// Thread safety: pure functions of their inputs (the classifier's Probability is const).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "analyzer/valetudo_map.h"
#include "fleet/v1/maps.pb.h"
#include "fleet/v1/telemetry.pb.h"
#include "slamcore/mapper.h"
#include "slamcore/occupancy_grid.h"
#include "slamcore/protrusion_classifier.h"
#include "slamcore/protrusion_detector.h"
#include "slamcore/se2.h"

namespace analyzer {

struct ComparisonOptions {
  slamcore::DetectorOptions detector;
  double min_wall_overlap = 0.5;   // below: the alignment is poor (a "misaligned" finding)
  double rotation_step_deg = 5.0;  // the registration's rotation search without a dock
  double residual_cap_m = 1.0;     // a wall cell farther than this (or outside the new map) counts this much
  double protrusion_probability = 0.5;
};

struct MapAlignment {
  slamcore::SE2 new_T_previous;  // a point of the previous map's world frame in the new map's world frame
  std::string method;  // "dock", "dock+registration", "registration", or "identity" (nothing converged)
  double wall_overlap = 0.0;  // fraction of previous wall cells within one cell of a new wall
  double residual_m = 0.0;    // their mean distance to the nearest new wall (capped at residual_cap_m)
  double correlation = 0.0;   // ECC's correlation coefficient of the registration, 0 when it did not run
  std::int64_t previous_wall_cells = 0;
  bool good = false;  // wall_overlap ≥ min_wall_overlap
};

struct ChangedRegion {
  slamcore::ProtrusionRegion region;   // cells and features on the new grid (lost: on the new grid too)
  std::array<double, 4> world_bbox{};  // min_x, min_y, max_x, max_y in the new map's frame
  double area_m2 = 0.0;                // after clean-up
  std::string predicted_class;  // new regions: "protrusion", "new_space" or "unclassified"; lost: "lost"
  double probability = -1.0;    // P(protrusion), −1 without a classifier
};

struct MapComparison {
  MapAlignment alignment;
  slamcore::OccupancyGrid aligned_previous;  // the previous grid on the new grid's cells
  std::vector<ChangedRegion> new_regions, lost_regions;
};

/// Aligns `previous` onto `next` (see above). INVALID_ARGUMENT when either grid is empty, the resolutions
/// differ, or the previous map has no wall cell to align by.
slamcore::Result<MapAlignment> AlignGrids(const slamcore::OccupancyGrid& previous,
                                          const slamcore::OccupancyGrid& next,
                                          const std::optional<slamcore::SE2>& previous_dock,
                                          const std::optional<slamcore::SE2>& next_dock,
                                          const ComparisonOptions& options = {});

/// `previous` resampled onto `next`'s cells through `new_T_previous`; cells it does not cover are unknown.
slamcore::Result<slamcore::OccupancyGrid> ResampleOnto(const slamcore::OccupancyGrid& previous,
                                                       const slamcore::OccupancyGrid& next,
                                                       const slamcore::SE2& new_T_previous);

/// Aligns, then extracts and classes the changed regions (`classifier` may be null: "unclassified").
slamcore::Result<MapComparison> CompareGrids(const slamcore::OccupancyGrid& previous,
                                             const slamcore::OccupancyGrid& next,
                                             const std::optional<slamcore::SE2>& previous_dock,
                                             const std::optional<slamcore::SE2>& next_dock,
                                             const slamcore::ProtrusionClassifier* classifier,
                                             const ComparisonOptions& options = {});

/// The comparison as findings of the new version, by severity and numbered from 1:
///   misaligned   the alignment is poor (open)          alignment  its method and quality (info)
///   new_region   one per new region, with class and box (open when classed protrusion, else info)
///   lost_region  one per lost region, with box (open)
std::vector<fleet::v1::MapFinding> ComparisonFindings(const MapComparison& comparison,
                                                      std::int64_t previous_version);

/// A grid as a map: one fixed node at the origin carrying the whole grid as its local map (how imported
/// maps are stored).
slamcore::Map MapOfGrid(const slamcore::OccupancyGrid& grid);

/// A map made elsewhere as the snapshot an import records: MapOfGrid, its format ("valetudo", "map_server"),
/// and the dock and robot poses the export named. Shared by `fleetctl import` and the dashboard's upload.
fleet::v1::MapSnapshot ImportedSnapshot(const slamcore::OccupancyGrid& grid, const std::string& format,
                                        const std::optional<slamcore::SE2>& dock,
                                        const std::optional<slamcore::SE2>& robot);
/// The same for a parsed ValetudoMap export (its grid, dock and robot).
fleet::v1::MapSnapshot ImportedSnapshot(const ValetudoMap& map);

/// The dock pose an imported snapshot carries (ImportedMapInfo.dock), if any.
std::optional<slamcore::SE2> DockOf(const fleet::v1::MapSnapshot& snapshot);

}  // namespace analyzer
