// Protrusions from physics (paper I and IV-C): range scans cast at the true place and drawn at the
// believed pose, the stuck-robot generator families, walls that turn to floor surviving the clean-up, and
// the built-in default model.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "range_scan.h"
#include "slamcore/protrusion_classifier.h"
#include "slamcore/protrusion_data.h"
#include "slamcore/protrusion_detector.h"
#include "test_data.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

constexpr std::int8_t kFree = 0, kOccupied = 100;

/// A 10 m × 5 m grid at 5 cm: a 5 m × 5 m room (walls on its border cells) on the left, unknown on the right.
OccupancyGrid RoomWithUnknownBeyond() {
  OccupancyGrid grid = *OccupancyGrid::Create(200, 100, 0.05);
  for (int row = 0; row < 100; ++row) {
    for (int col = 0; col < 100; ++col) {
      grid.at(col, row) = (col == 0 || col == 99 || row == 0 || row == 99) ? kOccupied : kFree;
    }
  }
  return grid;
}

std::size_t CellAt(const OccupancyGrid& grid, double x, double y) {
  return static_cast<std::size_t>(std::floor(y / grid.resolution)) * grid.width +
         static_cast<std::size_t>(std::floor(x / grid.resolution));
}

TEST(RangeScan, AScanDrawnAtTheBelievedPoseCopiesTheWallBeyondIt) {
  const OccupancyGrid world = RoomWithUnknownBeyond();
  internal::RangeSensor sensor{.range_m = 5.0, .field_of_view = 0.2, .range_noise_m = 0.0, .dropout = 0.0};
  std::mt19937_64 random(1);
  internal::ScanVotes votes(world);
  // The sensor at (2.5, 2.5) looks east: the wall's first cell (x 4.95–5.0) is 2.45 m ahead. Drawn 1 m
  // further east, the hit lands at x = 5.95 and floor is voted up to it, beyond the real wall.
  votes.AddScan(world, SE2(2.5, 2.5, 0.0), SE2(3.5, 2.5, 0.0), sensor, true, random);
  EXPECT_GE(votes.Occupied(CellAt(world, 5.96, 2.51)), 1);
  EXPECT_EQ(votes.Resolve(CellAt(world, 5.96, 2.51)), kOccupied);
  EXPECT_GE(votes.Free(CellAt(world, 5.5, 2.51)), 1);
  EXPECT_EQ(votes.Occupied(CellAt(world, 5.5, 2.51)), 0);
  EXPECT_TRUE(votes.MostlyErroneous(CellAt(world, 5.5, 2.51)));
  EXPECT_FALSE(votes.Voted(CellAt(world, 6.5, 2.51)));  // nothing past the copied wall
  EXPECT_FALSE(votes.Voted(CellAt(world, 3.0, 2.51)));  // the believed pose is the scan's origin

  // The same scan drawn where it was taken stops at the real wall.
  internal::ScanVotes true_votes(world);
  true_votes.AddScan(world, SE2(2.5, 2.5, 0.0), SE2(2.5, 2.5, 0.0), sensor, false, random);
  EXPECT_GE(true_votes.Occupied(CellAt(world, 4.96, 2.51)), 1);
  EXPECT_FALSE(true_votes.Voted(CellAt(world, 5.5, 2.51)));
  EXPECT_FALSE(true_votes.MostlyErroneous(CellAt(world, 4.0, 2.51)));
}

TEST(ProtrusionPhysics, HeldOutFamilyUsesRangesTrainingNeverSees) {
  const auto physical = GeneratorFamily("physical");
  const auto heldout = GeneratorFamily("heldout");
  ASSERT_THAT(physical, IsOk());
  ASSERT_THAT(heldout, IsOk());
  EXPECT_FALSE(GeneratorFamily("unknown").ok());
  auto overlaps = [](const Interval& a, const Interval& b) { return a.low < b.high && b.low < a.high; };
  for (const auto& train : physical->stuck.sensors) {
    for (const auto& test : heldout->stuck.sensors) {
      EXPECT_FALSE(overlaps(train.range_m, test.range_m));
      // Rotating lidars (2π) are in both; their ranges differ.
      if (train.field_of_view.high < 6.0 || test.field_of_view.high < 6.0) {
        EXPECT_FALSE(overlaps(train.field_of_view, test.field_of_view));
      }
    }
  }
  EXPECT_FALSE(overlaps(physical->stuck.push_deviation, heldout->stuck.push_deviation));
  EXPECT_EQ(heldout->stuck_robot_share, 1.0);
}

TEST(ProtrusionPhysics, StuckRobotsPaintBandsTheDetectorFinds) {
  TEST_DATA_FILE_OR_SKIP(map_path, "maps/aws_small_house.yaml");
  const auto map = ReadMapServerYaml(map_path.string());
  ASSERT_THAT(map, IsOk());
  const auto options = GeneratorFamily("heldout");
  ASSERT_THAT(options, IsOk());
  int protrusions = 0, protrusion_regions = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const auto pair = GeneratePair(*map, seed, *options);
    ASSERT_THAT(pair, IsOk());
    const auto again = GeneratePair(*map, seed, *options);
    EXPECT_EQ(pair->child.cells, again->child.cells);  // seeded
    protrusions += pair->protrusions;
    // Every protrusion cell is a change the detector can see: newly known, or a wall turned to floor.
    const auto aligned = AlignParentToChild(pair->parent, pair->child);
    ASSERT_THAT(aligned, IsOk());
    const auto difference = DifferenceMask(*aligned, pair->child);
    for (std::size_t i = 0; i < pair->truth.size(); ++i) {
      if (pair->truth[i] != 0) {
        ASSERT_EQ(difference[i], 1) << "cell " << i;
      }
    }
    // Parent and child are drawn on one grid here, so a detector without registration tolerance sees every
    // band (with the default 0.15 m, slivers of bands that hug known space are given up: README).
    DetectorOptions exact;
    exact.registration_tolerance_m = 0.0;
    const auto labelled = ExtractAndLabel(*pair, exact);
    ASSERT_THAT(labelled, IsOk());
    for (const int label : labelled->labels) protrusion_regions += label;
    EXPECT_EQ(labelled->missed_protrusions, 0);
  }
  EXPECT_GE(protrusions, 6);  // at least one stuck robot per pair
  EXPECT_GE(protrusion_regions, protrusions);
}

TEST(ProtrusionPhysics, TheMisregisteredFamilyIsTheHeldOutPairDrawnOff) {
  TEST_DATA_FILE_OR_SKIP(map_path, "maps/aws_small_house.yaml");
  const auto map = ReadMapServerYaml(map_path.string());
  ASSERT_THAT(map, IsOk());
  const auto heldout = GeneratorFamily("heldout");
  const auto misregistered = GeneratorFamily("misregistered");
  ASSERT_THAT(heldout, IsOk());
  ASSERT_THAT(misregistered, IsOk());
  EXPECT_GE(misregistered->registration_shift_m.low, 0.05);  // at least a cell off
  const auto aligned = GeneratePair(*map, 3, *heldout);
  const auto moved = GeneratePair(*map, 3, *misregistered);
  ASSERT_THAT(aligned, IsOk());
  ASSERT_THAT(moved, IsOk());
  // The same pair: the parent untouched, the child (and its truth) moved by the registration error.
  EXPECT_EQ(moved->parent.cells, aligned->parent.cells);
  EXPECT_NE(moved->child.cells, aligned->child.cells);
  EXPECT_EQ(moved->child.cells, GeneratePair(*map, 3, *misregistered)->child.cells);  // seeded
  const auto count = [](const std::vector<std::uint8_t>& truth, std::uint8_t label) {
    return std::count(truth.begin(), truth.end(), label);
  };
  const auto protrusion_cells = count(aligned->truth, 1);
  ASSERT_GT(protrusion_cells, 0);
  EXPECT_NEAR(count(moved->truth, 1), protrusion_cells, 0.05 * protrusion_cells);  // nearest-cell resampling
  // Drawn one or two cells off, the walls do not become changes: the detector reports about as many regions.
  const auto regions_aligned = ExtractRegions(aligned->parent, aligned->child);
  const auto regions_moved = ExtractRegions(moved->parent, moved->child);
  ASSERT_THAT(regions_aligned, IsOk());
  ASSERT_THAT(regions_moved, IsOk());
  EXPECT_LE(regions_moved->size(), regions_aligned->size() + 2);  // 7 and 7 here; 23 without the tolerance

  GeneratorOptions absurd = *misregistered;
  absurd.registration_shift_m = {0.0, 5.0};
  EXPECT_THAT(GeneratePair(*map, 3, absurd), StatusIs(StatusCode::kInvalidArgument));
}

TEST(ProtrusionDetector, AWallTurnedToFloorSurvivesTheCleanUp) {
  OccupancyGrid parent = RoomWithUnknownBeyond();
  OccupancyGrid child = parent;
  // A 1 m stretch of the 1-cell east wall becomes floor (rows 40–59); the 3×3 opening alone would erase it.
  for (int row = 40; row < 60; ++row) child.at(99, row) = kFree;
  const auto regions = ExtractRegions(parent, child);
  ASSERT_THAT(regions, IsOk());
  ASSERT_EQ(regions->size(), 1u);
  EXPECT_EQ((*regions)[0].clean_area_cells, 20);
  const auto& names = ProtrusionFeatureNames();
  const auto index = [&](const char* name) {
    return static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin());
  };
  EXPECT_NEAR((*regions)[0].features[index("crossed_wall_m2")], 20 * 0.0025, 1e-9);
  EXPECT_DOUBLE_EQ((*regions)[0].features[index("parent_wall_fraction")], 1.0);
}

TEST(ProtrusionDetector, ABandBeyondAWallIsUnreachableAndRepeatsTheRoom) {
  OccupancyGrid parent = RoomWithUnknownBeyond();
  OccupancyGrid child = parent;
  // A copy of the room's east 2 m, shifted 2 m east through the wall: floor, with the room's north and
  // south walls continued.
  for (int row = 0; row < 100; ++row) {
    for (int col = 100; col < 140; ++col) child.at(col, row) = parent.at(col - 40, row);
  }
  const auto regions = ExtractRegions(parent, child);
  ASSERT_THAT(regions, IsOk());
  ASSERT_EQ(regions->size(), 1u);
  const auto& names = ProtrusionFeatureNames();
  const auto feature = [&](const char* name) {
    return (*regions)[0]
        .features[static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin())];
  };
  EXPECT_DOUBLE_EQ(feature("reachable_fraction"), 0.0);  // only through the wall the parent holds
  EXPECT_GT(feature("wall_contact_fraction"), 0.2);
  EXPECT_GT(feature("shift_wall_match"), 0.9);  // the copied walls land on the room's own walls
  EXPECT_GT(feature("shift_floor_match"), 0.9);
  EXPECT_GE(feature("shift_distance_m"), 0.3);

  // The same band reached through a doorway in the wall is reachable.
  for (int row = 45; row < 55; ++row) child.at(99, row) = kFree, parent.at(99, row) = kFree;
  const auto through_door = ExtractRegions(parent, child);
  ASSERT_THAT(through_door, IsOk());
  ASSERT_EQ(through_door->size(), 1u);
  EXPECT_GT((*through_door)[0].features[static_cast<std::size_t>(
                std::find(names.begin(), names.end(), "reachable_fraction") - names.begin())],
            0.99);
}

TEST(DefaultProtrusionModel, IsBuiltInAndRoundTrips) {
  const auto model = DefaultProtrusionClassifier();
  ASSERT_THAT(model, IsOk());
  const auto bytes = (*model)->ToBytes();
  ASSERT_THAT(bytes, IsOk());
  const auto again = ProtrusionClassifier::LoadFromBytes(*bytes);
  ASSERT_THAT(again, IsOk());
  EXPECT_EQ((*again)->kind(), (*model)->kind());
  EXPECT_EQ((*again)->selected_features(), (*model)->selected_features());
  std::vector<double> features(ProtrusionFeatureNames().size(), 0.5);
  EXPECT_DOUBLE_EQ(*(*again)->Probability(features), *(*model)->Probability(features));
  EXPECT_FALSE(ProtrusionClassifier::LoadFromBytes("").ok());
  EXPECT_FALSE(ProtrusionClassifier::LoadFromBytes("format: something-else\n").ok());
}

}  // namespace
}  // namespace slamcore
