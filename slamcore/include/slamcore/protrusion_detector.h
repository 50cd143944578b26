// Erroneous-protrusion detection, the geometric half (paper IV-C, Fig. 5): parent/child difference,
// clean-up, connected regions, per-region features, ANOVA F-values for feature selection, and repair.
// The classifier that labels the regions is in protrusion_classifier.h.
//
// Pipeline (ExtractRegions):
//  1. Align the parent onto the child's cells: equal resolution and yaw, origins an integer number of cells
//     apart (the map grows, it is not resampled); anything else is refused with a Status saying why.
//  2. Difference: child cells that are new — known in the child and unknown (or outside) in the parent, or
//     free in the child where the parent had a wall (a door opened, a slip through a wall).
//  3. Clean-up: a morphological opening of `clean_up_size_m` removes sensor speckle and the 1–2-cell fringes
//     a re-scan adds along known edges; regions under `min_region_area_m2` are dropped, and so are regions
//     that a registration error of `registration_tolerance_m` explains: every one of their cells lies that
//     close to what the parent already knew (a newly known cell near a known one, a wall turned floor next
//     to the child's own wall). Two maps of one home are never drawn on exactly the same grid: a wall drawn
//     one cell off is not a change.
//  4. Connected regions (8-connectivity), each with the features of ProtrusionFeatureNames(), in metres so
//     that a model trained at one resolution transfers to another.
//
// Thread safety: free functions on values.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "slamcore/occupancy_grid.h"
#include "slamcore/status.h"

namespace slamcore {

/// The features in the order ExtractRegions computes them. The first six are the paper's; the others are
/// ours (why each helps is in docs/protrusion-data.md). Models record this list and refuse a different one.
const std::vector<std::string>& ProtrusionFeatureNames();

struct DetectorOptions {
  double clean_up_size_m = 0.10;     // opening kernel side; 3 cells at 5 cm
  double min_region_area_m2 = 0.05;  // 20 cells at 5 cm: smaller regions are noise, not space or slip
  /// How far apart two maps of the same place may be drawn: a region all of whose cells are this close to
  /// the parent's knowledge is a misregistration, not a change. Three cells at 5 cm: a wall drawn one or
  /// two cells off after a dock-and-image alignment is within it; a robot-wide band (0.3 m) or a doorway
  /// (0.7 m) is not.
  double registration_tolerance_m = 0.15;
};
inline constexpr double kMaxRegistrationToleranceM = 1.0;
/// The finest map the detector takes: its clean-up, tolerance and shift search are lengths in metres, so
/// their kernels grow as the cells shrink. Robot maps are drawn at 1–10 cm.
inline constexpr double kMinDetectorResolutionM = 0.001;
/// The largest child map the detector takes (a quarter of the largest grid: 250 m × 250 m at 5 cm), which
/// bounds its memory (labels, features' distance transforms) to about a gigabyte.
inline constexpr std::int64_t kMaxDetectorCells = 25'000'000;

/// A bounding box in the child map's IMAGE (x right, y down from the top-left, as in the PGM), in cells.
struct ImageBox {
  int x = 0, y = 0, width = 0, height = 0;
};

struct ProtrusionRegion {
  int id = 0;
  ImageBox bbox;
  std::vector<std::int32_t>
      cells;  // child grid indices the region changed (for repair), incl. its edge walls
  std::int64_t clean_area_cells = 0;  // cells after clean-up (what the features describe)
  std::vector<double> features;       // ProtrusionFeatureNames() order
};

/// The parent resampled (shifted) onto the child's cells; cells the parent does not cover are unknown.
Result<OccupancyGrid> AlignParentToChild(const OccupancyGrid& parent, const OccupancyGrid& child);

/// Steps 1–4 above. Fails when the maps cannot be aligned or either is empty or malformed.
Result<std::vector<ProtrusionRegion>> ExtractRegions(const OccupancyGrid& parent, const OccupancyGrid& child,
                                                     const DetectorOptions& options = {});

/// The raw difference mask of step 2 on an ALIGNED pair (1 = new), exposed for tests and the benchmark.
std::vector<std::uint8_t> DifferenceMask(const OccupancyGrid& aligned_parent, const OccupancyGrid& child);

/// One-way ANOVA of each feature across classes (labels 0..k−1): F = between-class mean square over
/// within-class mean square, p = P(F(k−1, N−k) > F) from Boost.Math's Fisher F distribution.
struct FeatureAnova {
  std::string name;
  double f_value = 0.0;
  double p_value = 1.0;
};
Result<std::vector<FeatureAnova>> AnovaFValues(const std::vector<std::vector<double>>& features,
                                               const std::vector<int>& labels);

/// Repair (paper IV-C): either cut the protrusion regions out of the child (their cells take the aligned
/// parent's values back), or fall back to the parent map altogether.
enum class RepairMode { kCutOut, kFallBackToParent };
OccupancyGrid RepairChild(const OccupancyGrid& aligned_parent, const OccupancyGrid& child,
                          const std::vector<const ProtrusionRegion*>& protrusions, RepairMode mode);

/// The paper's Fig. 5 as a PNG: (a) parent, (b) child, (c) difference (raw in grey, after clean-up in
/// white), (d) the regions classified (red protrusion, green new space) with their ids, side by side.
Result<std::string> RenderDetectionFigure(const OccupancyGrid& aligned_parent, const OccupancyGrid& child,
                                          const std::vector<ProtrusionRegion>& regions,
                                          const std::vector<bool>& is_protrusion);

}  // namespace slamcore
