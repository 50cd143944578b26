// Protrusion detection (paper IV-C): alignment and refusals, clean-up, region features on drawn shapes,
// ANOVA against a hand computation, repair.
#include "slamcore/protrusion_detector.h"

#include <gtest/gtest.h>

#include <cmath>

#include "status_matchers.h"

namespace slamcore {
namespace {

constexpr std::int8_t kFree = 0, kOccupied = 100;

std::size_t Feature(const std::string& name) {
  const auto& names = ProtrusionFeatureNames();
  return static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin());
}

void FillRect(OccupancyGrid& grid, int col0, int row0, int cols, int rows, std::int8_t value) {
  for (int row = row0; row < row0 + rows; ++row) {
    for (int col = col0; col < col0 + cols; ++col) grid.at(col, row) = value;
  }
}

/// A 200×200 parent with a known 4 m room; the child adds a 0.35 m × 3 m slip corridor out of the right
/// wall and a 3 m × 3 m room below.
struct Scene {
  OccupancyGrid parent, child;
};
Scene MakeScene() {
  Scene scene{*OccupancyGrid::Create(200, 200, 0.05), {}};
  FillRect(scene.parent, 40, 80, 82, 82, kOccupied);
  FillRect(scene.parent, 41, 81, 80, 80, kFree);
  scene.child = scene.parent;
  FillRect(scene.child, 121, 110, 60, 9, kOccupied);  // corridor rim…
  FillRect(scene.child, 120, 111, 60, 7, kFree);      // …and its free inside, through the wall
  FillRect(scene.child, 50, 19, 62, 62, kOccupied);   // a room below, sharing the parent's wall
  FillRect(scene.child, 51, 20, 60, 60, kFree);
  FillRect(scene.child, 70, 80, 16, 1, kFree);  // its door through the parent's wall
  return scene;
}

TEST(ProtrusionDetector, FindsTheCorridorAndTheRoomWithTheirShapes) {
  const Scene scene = MakeScene();
  auto regions = ExtractRegions(scene.parent, scene.child);
  ASSERT_THAT(regions, IsOk());
  ASSERT_EQ(regions->size(), 2u);
  const ProtrusionRegion* corridor = nullptr;
  const ProtrusionRegion* room = nullptr;
  for (const ProtrusionRegion& region : *regions)
    (region.bbox.width > region.bbox.height ? corridor : room) = &region;
  ASSERT_NE(corridor, nullptr);
  ASSERT_NE(room, nullptr);
  // Image coordinates: grid rows 110..118 are image rows 200-119 = 81 .. 89.
  EXPECT_EQ(corridor->bbox.y, 81);
  EXPECT_EQ(corridor->bbox.height, 9);
  EXPECT_NEAR(corridor->bbox.x, 120, 1);
  EXPECT_GT(room->bbox.y, 110);  // the room is below the parent's room in the image
  EXPECT_LT(corridor->features[Feature("max_distance_m")], 0.3);
  EXPECT_GT(room->features[Feature("max_distance_m")], 1.0);
  EXPECT_NEAR(corridor->features[Feature("area_m2")], 60 * 9 * 0.0025, 0.1);
  // The equal-second-moment ellipse of an L × W rectangle has axes 4·L/√12 and 4·W/√12 (as regionprops).
  EXPECT_NEAR(corridor->features[Feature("major_axis_m")], 3.0 * 4 / std::sqrt(12.0), 0.1);
  EXPECT_NEAR(corridor->features[Feature("minor_axis_m")], 0.45 * 4 / std::sqrt(12.0), 0.05);
  EXPECT_GT(corridor->features[Feature("elongation")], 5.0);
  EXPECT_GT(corridor->features[Feature("wall_fraction")], 0.15);
  EXPECT_LT(room->features[Feature("wall_fraction")], 0.1);
  EXPECT_GT(corridor->features[Feature("parent_wall_fraction")], 0.0);
  for (const ProtrusionRegion& region : *regions) {
    ASSERT_EQ(region.features.size(), ProtrusionFeatureNames().size());
    for (const double value : region.features) EXPECT_TRUE(std::isfinite(value));
  }
}

// The clean-up runs in a window around each region, or over the whole pair when the windows of many
// regions close together would cover more: either way a region is described by what lies near it.
TEST(ProtrusionDetector, ARegionIsDescribedTheSameBesideManyOthers) {
  const Scene scene = MakeScene();
  auto alone = ExtractRegions(scene.parent, scene.child);
  ASSERT_THAT(alone, IsOk());
  // The same scene in the lower half of a canvas twice as tall, whose upper half holds 100 one-cell-wide
  // strips 150 cells long (speckle the clean-up removes), each with its window: together far more than
  // the canvas.
  Scene crowded{*OccupancyGrid::Create(200, 400, 0.05), *OccupancyGrid::Create(200, 400, 0.05)};
  for (int row = 0; row < 200; ++row) {
    for (int col = 0; col < 200; ++col) {
      crowded.parent.at(col, row) = scene.parent.at(col, row);
      crowded.child.at(col, row) = scene.child.at(col, row);
    }
  }
  for (int strip = 0; strip < 100; ++strip) FillRect(crowded.child, 2 * strip, 240, 1, 150, kFree);
  auto beside = ExtractRegions(crowded.parent, crowded.child);
  ASSERT_THAT(beside, IsOk());
  ASSERT_EQ(beside->size(), alone->size());
  for (std::size_t k = 0; k < alone->size(); ++k) {
    EXPECT_EQ((*beside)[k].features, (*alone)[k].features) << "region " << k;
    EXPECT_EQ((*beside)[k].clean_area_cells, (*alone)[k].clean_area_cells);
    EXPECT_EQ((*beside)[k].cells.size(), (*alone)[k].cells.size());
  }
}

TEST(ProtrusionDetector, CleanUpRemovesSpeckleAndFringes) {
  Scene scene = MakeScene();
  scene.child = scene.parent;
  for (int i = 0; i < 30; ++i) FillRect(scene.child, 5 + 6 * i % 180, 5 + (i * 37) % 60, 2, 2, kFree);
  FillRect(scene.child, 40, 162, 60, 1, kFree);  // a 1-cell fringe along the known edge
  auto regions = ExtractRegions(scene.parent, scene.child);
  ASSERT_THAT(regions, IsOk());
  EXPECT_TRUE(regions->empty());
}

/// `grid` drawn `cols` cells right and `rows` cells up on a grid of the same size and origin, as a later map of
/// the same home aligned only as well as registration allows.
OccupancyGrid DrawnOff(const OccupancyGrid& grid, int cols, int rows) {
  OccupancyGrid moved = *OccupancyGrid::Create(grid.width, grid.height, grid.resolution);
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      if (col + cols >= 0 && col + cols < grid.width && row + rows >= 0 && row + rows < grid.height)
        moved.at(col + cols, row + rows) = grid.at(col, row);
    }
  }
  return moved;
}

TEST(ProtrusionDetector, RegistrationToleranceIgnoresWallsDrawnACellOffAndKeepsTheChanges) {
  const Scene scene = MakeScene();
  DetectorOptions exact;
  exact.registration_tolerance_m = 0.0;
  // The parent itself, drawn two cells (0.10 m) right and one up: nothing changed. Without the tolerance the
  // right wall, drawn beside itself, is a 4 m "wall turned floor" that survives the clean-up.
  const OccupancyGrid same_home = DrawnOff(scene.parent, 2, 1);
  const auto strict = ExtractRegions(scene.parent, same_home, exact);
  ASSERT_THAT(strict, IsOk());
  EXPECT_FALSE(strict->empty());
  const auto tolerant = ExtractRegions(scene.parent, same_home);
  ASSERT_THAT(tolerant, IsOk());
  EXPECT_TRUE(tolerant->empty());
  // Three cells off (0.15 m) is still within the tolerance; five (0.25 m) is not.
  const auto three = ExtractRegions(scene.parent, DrawnOff(scene.parent, 3, 0));
  ASSERT_THAT(three, IsOk());
  EXPECT_TRUE(three->empty());
  const auto five = ExtractRegions(scene.parent, DrawnOff(scene.parent, 5, 0));
  ASSERT_THAT(five, IsOk());
  EXPECT_FALSE(five->empty());

  // The child with its corridor and room, drawn two cells off: both changes are still found, and the
  // corridor is still robot-wide (the strip along the wall it leaves is part of its region: a registration
  // error touching a real change is described with it).
  const auto regions = ExtractRegions(scene.parent, DrawnOff(scene.child, 2, 1));
  ASSERT_THAT(regions, IsOk());
  ASSERT_EQ(regions->size(), 2u);
  const ProtrusionRegion& corridor =
      (*regions)[0].clean_area_cells < (*regions)[1].clean_area_cells ? (*regions)[0] : (*regions)[1];
  const ProtrusionRegion& room = &corridor == &(*regions)[0] ? (*regions)[1] : (*regions)[0];
  EXPECT_LT(corridor.features[Feature("max_distance_m")], 0.3);
  EXPECT_GT(room.features[Feature("max_distance_m")], 1.0);

  DetectorOptions negative;
  negative.registration_tolerance_m = -0.1;
  EXPECT_THAT(ExtractRegions(scene.parent, scene.child, negative), StatusIs(StatusCode::kInvalidArgument));
  DetectorOptions absurd;
  absurd.registration_tolerance_m = 1e9;
  EXPECT_THAT(ExtractRegions(scene.parent, scene.child, absurd), StatusIs(StatusCode::kInvalidArgument));
}

TEST(ProtrusionDetector, AlignsWholeCellShiftsAndRefusesWhatCannotBeAligned) {
  const Scene scene = MakeScene();
  // The parent cropped: 30 cells less on the left, 10 below; the same map content.
  OccupancyGrid cropped = *OccupancyGrid::Create(170, 190, 0.05, 30 * 0.05, 10 * 0.05);
  for (int row = 0; row < 190; ++row) {
    for (int col = 0; col < 170; ++col) cropped.at(col, row) = scene.parent.at(col + 30, row + 10);
  }
  auto regions = ExtractRegions(cropped, scene.child);
  ASSERT_THAT(regions, IsOk());
  EXPECT_EQ(regions->size(), 2u);

  OccupancyGrid coarse = scene.parent;
  coarse.resolution = 0.1;
  auto refused = ExtractRegions(coarse, scene.child);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("different resolutions"), std::string::npos);
  OccupancyGrid shifted = scene.parent;
  shifted.origin_x += 0.013;
  refused = ExtractRegions(shifted, scene.child);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("whole number of cells"), std::string::npos);
  OccupancyGrid turned = scene.parent;
  turned.origin_yaw = 0.5;
  EXPECT_FALSE(ExtractRegions(turned, scene.child).ok());
  refused = ExtractRegions(OccupancyGrid{}, scene.child);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("empty"), std::string::npos);
  OccupancyGrid broken = scene.child;
  broken.cells.pop_back();
  EXPECT_FALSE(ExtractRegions(scene.parent, broken).ok());
  // A resolution written in the wrong unit (micrometres for metres) would make the 0.15 m tolerance a disk
  // of 300,000 cells a side: refused, naming the resolution, before anything is allocated.
  OccupancyGrid fine_parent = scene.parent, fine_child = scene.child;
  fine_parent.resolution = fine_child.resolution = 1e-7;
  refused = ExtractRegions(fine_parent, fine_child);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("mm per cell are finer"), std::string::npos);
  // A child larger than the detector's bound (its labels and distance transforms would take gigabytes).
  OccupancyGrid huge = *OccupancyGrid::Create(5001, 5000, 0.05);
  refused = ExtractRegions(huge, huge);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("5001 x 5000 cells, more than"), std::string::npos)
      << refused.status().ToString();
}

TEST(ProtrusionAnova, MatchesAHandComputedOneWayAnova) {
  // Groups {1,2,3} and {4,5,6}: SSB = 13.5, SSW = 4, F = 13.5 / (4 / 4) = 13.5, p = P(F(1,4) > 13.5),
  // which equals the two-sided t-test p for t = sqrt(13.5) with 4 dof: 0.021312.
  std::vector<std::vector<double>> features;
  std::vector<int> labels;
  for (int i = 1; i <= 6; ++i) {
    features.push_back(std::vector<double>(ProtrusionFeatureNames().size(), 1.0));
    features.back()[0] = i;
    features.back()[1] = (i % 2) * 10.0;  // no information about the class
    labels.push_back(i <= 3 ? 0 : 1);
  }
  auto anova = AnovaFValues(features, labels);
  ASSERT_THAT(anova, IsOk());
  EXPECT_EQ((*anova)[0].name, "area_m2");
  EXPECT_NEAR((*anova)[0].f_value, 13.5, 1e-9);
  EXPECT_NEAR((*anova)[0].p_value, 0.021312, 1e-5);
  EXPECT_GT((*anova)[1].p_value, 0.5);
  EXPECT_EQ((*anova)[2].f_value, 0.0);  // constant feature
  EXPECT_FALSE(AnovaFValues(features, {0, 0, 0, 0, 0, 0}).ok());
  EXPECT_FALSE(AnovaFValues(features, {0, 1}).ok());
}

TEST(ProtrusionRepair, CutOutRestoresTheParentWhereTheProtrusionWas) {
  const Scene scene = MakeScene();
  auto aligned = AlignParentToChild(scene.parent, scene.child);
  ASSERT_THAT(aligned, IsOk());
  auto regions = ExtractRegions(scene.parent, scene.child);
  ASSERT_THAT(regions, IsOk());
  const ProtrusionRegion* corridor = nullptr;
  for (const ProtrusionRegion& region : *regions) {
    if (region.bbox.width > region.bbox.height) corridor = &region;
  }
  ASSERT_NE(corridor, nullptr);
  const OccupancyGrid repaired = RepairChild(*aligned, scene.child, {corridor}, RepairMode::kCutOut);
  for (int row = 105; row < 125; ++row) {
    for (int col = 118; col < 185; ++col)
      EXPECT_EQ(repaired.at(col, row), scene.parent.at(col, row)) << col << "," << row;
  }
  EXPECT_EQ(repaired.at(80, 50), kFree);  // the new room stays
  EXPECT_EQ(RepairChild(*aligned, scene.child, {}, RepairMode::kFallBackToParent).cells, scene.parent.cells);
}

}  // namespace
}  // namespace slamcore
