// Comparison of map-only versions (analyzer/map_comparison.h): a synthetic home moved by a known transform is
// found again by registration alone and by the dock, an added room is the one new region and a removed room
// the one lost region, bad input is refused naming what is wrong, and the real home d9_1058 at two times
// (data/valetudo) aligns with the figures below.
#include "analyzer/map_comparison.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>

#include "analyzer/valetudo_map.h"
#include "slamcore/protrusion_data.h"
#include "test_data.h"
#include "status_matchers.h"

namespace analyzer {
namespace {

using slamcore::CellState;
using slamcore::OccupancyGrid;
using slamcore::SE2;

/// An axis-aligned room [x0, x1] × [y0, y1] with 0.1 m walls, in home coordinates.
struct Room {
  double x0, y0, x1, y1;
  bool Inside(double x, double y) const { return x >= x0 && x <= x1 && y >= y0 && y <= y1; }
  bool Interior(double x, double y) const {
    return x > x0 + 0.1 && x < x1 - 0.1 && y > y0 + 0.1 && y < y1 - 0.1;
  }
};

/// A grid whose cell centres, carried into the home frame by home_T_grid, are free inside a room's interior
/// and occupied on its walls (interiors win, so rooms sharing a wall get a doorway-free shared wall).
OccupancyGrid Draw(const std::vector<Room>& rooms, const SE2& home_T_grid, double origin_x, double origin_y) {
  auto grid = OccupancyGrid::Create(200, 160, 0.05, origin_x, origin_y);
  EXPECT_THAT(grid, IsOk());
  for (int row = 0; row < grid->height; ++row) {
    for (int col = 0; col < grid->width; ++col) {
      const slamcore::Vector2 home =
          home_T_grid * slamcore::Vector2(origin_x + (col + 0.5) * 0.05, origin_y + (row + 0.5) * 0.05);
      for (const Room& room : rooms) {
        if (room.Interior(home.x(), home.y())) {
          grid->at(col, row) = static_cast<std::int8_t>(CellState::kFree);
          break;
        }
        if (room.Inside(home.x(), home.y()))
          grid->at(col, row) = static_cast<std::int8_t>(CellState::kOccupied);
      }
    }
  }
  return std::move(grid).value();
}

const Room kHall{0.5, 0.5, 5.0, 4.0};
const Room kKitchen{5.0, 0.5, 7.5, 3.0};  // 2.5 × 2.5 m beside the hall

TEST(MapComparison, RegistrationFindsAMovedHomeAndTheNewRoom) {
  const OccupancyGrid previous = Draw({kHall}, SE2(), 0.0, 0.0);
  // The new export's frame: rotated by 20° and shifted, as a robot that re-localised elsewhere would save it.
  const SE2 home_T_new(1.0, -0.5, 20.0 * std::numbers::pi / 180.0);
  const OccupancyGrid next = Draw({kHall, kKitchen}, home_T_new, -1.0, -1.5);
  const auto comparison = CompareGrids(previous, next, std::nullopt, std::nullopt, nullptr);
  ASSERT_THAT(comparison, IsOk());
  const MapAlignment& alignment = comparison->alignment;
  EXPECT_EQ(alignment.method, "registration");
  const SE2 expected = home_T_new.inverse();  // new_T_previous: previous = home frame
  EXPECT_NEAR(alignment.new_T_previous.x(), expected.x(), 0.05);
  EXPECT_NEAR(alignment.new_T_previous.y(), expected.y(), 0.05);
  EXPECT_NEAR(alignment.new_T_previous.theta(), expected.theta(), 1.0 * std::numbers::pi / 180.0);
  EXPECT_TRUE(alignment.good);
  EXPECT_GT(alignment.wall_overlap, 0.95);
  EXPECT_LT(alignment.residual_m, 0.03);
  // The kitchen's interior (2.3 × 2.3 m, less the cleaned edges) is the one new region; nothing is lost.
  ASSERT_EQ(comparison->new_regions.size(), 1u);
  EXPECT_NEAR(comparison->new_regions[0].area_m2, 2.4 * 2.5, 0.8);
  EXPECT_EQ(comparison->new_regions[0].predicted_class, "unclassified");
  EXPECT_TRUE(comparison->lost_regions.empty());
  const auto& box = comparison->new_regions[0].world_bbox;
  const slamcore::Vector2 centre =
      home_T_new.inverse() * slamcore::Vector2(6.25, 1.75);  // kitchen centre, new frame
  EXPECT_GT(centre.x(), box[0]);
  EXPECT_LT(centre.x(), box[2]);
  EXPECT_GT(centre.y(), box[1]);
  EXPECT_LT(centre.y(), box[3]);
}

TEST(MapComparison, DockAlignsAndALostRoomIsReported) {
  const SE2 home_T_new(0.3, 0.2, 5.0 * std::numbers::pi / 180.0);
  const OccupancyGrid previous = Draw({kHall, kKitchen}, SE2(), 0.0, 0.0);
  const OccupancyGrid next = Draw({kHall}, home_T_new, 0.0, 0.0);
  const SE2 dock_home(2.0, 0.7, std::numbers::pi / 2);
  const auto comparison = CompareGrids(previous, next, dock_home, home_T_new.inverse() * dock_home, nullptr);
  ASSERT_THAT(comparison, IsOk());
  EXPECT_EQ(comparison->alignment.method.rfind("dock", 0), 0u) << comparison->alignment.method;
  // The kitchen's own walls (7.5 of 23.5 m of wall) are gone: they count as misses.
  EXPECT_GT(comparison->alignment.wall_overlap, 0.6);
  EXPECT_TRUE(comparison->new_regions.empty());
  ASSERT_EQ(comparison->lost_regions.size(), 1u);
  EXPECT_NEAR(comparison->lost_regions[0].area_m2, 2.4 * 2.5, 0.8);

  const auto findings = ComparisonFindings(*comparison, 3);
  ASSERT_EQ(findings.size(), 2u);
  EXPECT_EQ(findings[0].finding_kind(), fleet::v1::FINDING_KIND_LOST_REGION);
  EXPECT_EQ(findings[0].finding_id(), 1);
  EXPECT_EQ(findings[0].world_bbox_size(), 4);
  EXPECT_EQ(findings[1].finding_kind(), fleet::v1::FINDING_KIND_ALIGNMENT);
  EXPECT_EQ(findings[1].finding_state(), fleet::v1::FINDING_STATE_INFO);
  EXPECT_NE(findings[1].summary().find("version 3"), std::string::npos) << findings[1].summary();
}

TEST(MapComparison, AWrongDockFallsBackToRegistration) {
  const OccupancyGrid room = Draw({kHall, kKitchen}, SE2(), 0.0, 0.0);
  // The same map, but docks 2 m and 90° apart: the dock alone says the home turned, its walls land on none
  // (even refined), so registration alone runs and finds the true pose, the identity.
  auto alignment = AlignGrids(room, room, SE2(1, 1, 0), SE2(3, 1, std::numbers::pi / 2));
  ASSERT_THAT(alignment, IsOk());
  EXPECT_EQ(alignment->method, "registration");
  EXPECT_TRUE(alignment->good);
  EXPECT_GT(alignment->wall_overlap, 0.99);
  EXPECT_NEAR(alignment->new_T_previous.x(), 0.0, 0.05);
  EXPECT_NEAR(alignment->new_T_previous.y(), 0.0, 0.05);
  EXPECT_NEAR(alignment->new_T_previous.theta(), 0.0, 0.02);
  MapComparison comparison;
  comparison.alignment = *alignment;
  EXPECT_EQ(ComparisonFindings(comparison, 1)[0].finding_kind(),
            alignment->good ? fleet::v1::FINDING_KIND_ALIGNMENT : fleet::v1::FINDING_KIND_MISALIGNED);
  // A poor alignment is an open "misaligned" finding, first by severity.
  comparison.alignment.good = false;
  comparison.alignment.wall_overlap = 0.2;
  comparison.new_regions.push_back({.area_m2 = 1.0, .predicted_class = "new_space"});
  const auto findings = ComparisonFindings(comparison, 1);
  ASSERT_EQ(findings.size(), 2u);
  EXPECT_EQ(findings[0].finding_kind(), fleet::v1::FINDING_KIND_MISALIGNED);
  EXPECT_EQ(findings[0].finding_state(), fleet::v1::FINDING_STATE_OPEN);
  EXPECT_EQ(findings[1].finding_kind(), fleet::v1::FINDING_KIND_NEW_REGION);
  EXPECT_EQ(findings[1].finding_state(), fleet::v1::FINDING_STATE_INFO);
}

TEST(MapComparison, RefusesWhatCannotBeCompared) {
  const OccupancyGrid room = Draw({kHall}, SE2(), 0.0, 0.0);
  OccupancyGrid coarse = room;
  coarse.resolution = 0.1;
  auto refused = AlignGrids(room, coarse, std::nullopt, std::nullopt);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("resolution"), std::string::npos) << refused.status().ToString();
  auto blank = OccupancyGrid::Create(10, 10, 0.05);
  ASSERT_THAT(blank, IsOk());
  refused = AlignGrids(*blank, room, std::nullopt, std::nullopt);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("previous map: no wall"), std::string::npos)
      << refused.status().ToString();
  refused = AlignGrids(room, OccupancyGrid{}, std::nullopt, std::nullopt);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("new map: empty"), std::string::npos)
      << refused.status().ToString();
}

/// The real home d9_1058 exported at two times (data/valetudo/SOURCES.md): the later export knows more of
/// the home (a room at the top, y 512–569 in map pixels) and its dock moved 0.53 m in Valetudo's frame.
TEST(MapComparison, RealHomeAtTwoTimes) {
  TEST_DATA_FILE_OR_SKIP(before_path, "valetudo/dreame_d9_1058_no_segments.json");
  TEST_DATA_FILE_OR_SKIP(after_path, "valetudo/dreame_d9_1058_with_segments.json");
  const auto before = ReadValetudoMap(before_path.string());
  const auto after = ReadValetudoMap(after_path.string());
  ASSERT_THAT(before, IsOk());
  ASSERT_THAT(after, IsOk());
  ASSERT_TRUE(before->dock && after->dock);
  const auto by_dock =
      CompareGrids(before->grid, after->grid, before->dock->pose, after->dock->pose, nullptr);
  ASSERT_THAT(by_dock, IsOk());
  const auto by_image = CompareGrids(before->grid, after->grid, std::nullopt, std::nullopt, nullptr);
  ASSERT_THAT(by_image, IsOk());
  for (const MapComparison* comparison : {&*by_dock, &*by_image}) {
    const MapAlignment& a = comparison->alignment;
    std::printf(
        "%s: overlap %.3f residual %.3f m correlation %.3f shift (%.3f, %.3f) m %.2f°; %zu new, %zu lost\n",
        a.method.c_str(), a.wall_overlap, a.residual_m, a.correlation, a.new_T_previous.x(),
        a.new_T_previous.y(), a.new_T_previous.theta() * 180 / std::numbers::pi,
        comparison->new_regions.size(), comparison->lost_regions.size());
    // The dock moved 0.53 m along x (charger_location 3303 → 3356 cm): the home moved with it, not rotated.
    EXPECT_NEAR(a.new_T_previous.x(), 0.55, 0.05);
    EXPECT_NEAR(a.new_T_previous.y(), 0.0, 0.05);
    EXPECT_NEAR(a.new_T_previous.theta(), 0.0, 0.5 * std::numbers::pi / 180.0);
    // Two thirds of the earlier walls land on walls (the rest were re-traced elsewhere or opened), 0.12 m apart
    // on average: good, but far from identical exports.
    EXPECT_TRUE(a.good);
    EXPECT_NEAR(a.wall_overlap, 0.67, 0.03);
    EXPECT_NEAR(a.residual_m, 0.12, 0.02);
    // One large new region, the room at the top (map pixels y 512–569 in the later export, world y above
    // −28.5 m), and a few fringes under 1 m²; the earlier map's parts missing later are small.
    // Nine: the wall the later export draws one cell beside the earlier one is a registration error, not a
    // change (the detector's registration tolerance).
    ASSERT_EQ(comparison->new_regions.size(), 9u);
    const auto largest = std::max_element(
        comparison->new_regions.begin(), comparison->new_regions.end(),
        [](const ChangedRegion& a, const ChangedRegion& b) { return a.area_m2 < b.area_m2; });
    EXPECT_NEAR(largest->area_m2, 13.75, 0.5);
    EXPECT_GT(largest->world_bbox[3], -26.0);
    EXPECT_LT(largest->world_bbox[1], -28.5);
    for (const ChangedRegion& region : comparison->new_regions) {
      if (&region != &*largest) EXPECT_LT(region.area_m2, 1.0);
    }
    // Four lost: two patches and two stretches of wall the earlier export had as floor (kept through the
    // clean-up as walls turned to floor are; a third lies beside the earlier export's own wall, within the
    // registration tolerance).
    ASSERT_EQ(comparison->lost_regions.size(), 4u);
    for (const ChangedRegion& region : comparison->lost_regions) EXPECT_LT(region.area_m2, 0.3);
  }
  EXPECT_EQ(by_dock->alignment.method, "dock+registration");
  EXPECT_EQ(by_image->alignment.method, "registration");
}

/// Two exports compared as fleetd compares imports: aligned by their docks, regions classed by `classifier`.
slamcore::Result<MapComparison> CompareExportsByDock(const std::filesystem::path& before_path,
                                                     const std::filesystem::path& after_path,
                                                     const slamcore::ProtrusionClassifier* classifier) {
  ASSIGN_OR_RETURN(const auto before, ReadValetudoMap(before_path.string()));
  ASSIGN_OR_RETURN(const auto after, ReadValetudoMap(after_path.string()));
  return CompareGrids(before.grid, after.grid, before.dock->pose, after.dock->pose, classifier);
}

/// The regions of d9_1058's second export classed as runs' regions are, by a random forest trained (as
/// `slamtool train-protrusions` and the models service do) on generated pairs of the OTHER homes in data/maps:
/// the room that appeared is new space, not a protrusion.
TEST(MapComparison, RealHomeRegionsClassedByAModelOfOtherHomes) {
  TEST_DATA_FILE_OR_SKIP(before_path, "valetudo/dreame_d9_1058_no_segments.json");
  TEST_DATA_FILE_OR_SKIP(after_path, "valetudo/dreame_d9_1058_with_segments.json");
  std::vector<slamcore::LabelledRegion> training;
  for (const char* id : {"aws_small_house", "valetudo_dreame_1c_1096_fullcleanup",
                         "valetudo_roborock_S5_FW2008_with_segments"}) {
    const auto map =
        slamcore::ReadMapServerYaml((test_data::Sample() / "maps" / (std::string(id) + ".yaml")).string());
    ASSERT_THAT(map, IsOk());
    for (std::uint64_t variant = 0; variant < 6; ++variant) {
      const auto pair = slamcore::GeneratePair(*map, 1000 + variant);
      ASSERT_THAT(pair, IsOk());
      const auto labelled = slamcore::ExtractAndLabel(*pair);
      ASSERT_THAT(labelled, IsOk());
      for (std::size_t i = 0; i < labelled->regions.size(); ++i) {
        training.push_back({id, labelled->regions[i].features, labelled->labels[i]});
      }
    }
  }
  const auto classifier = slamcore::ProtrusionClassifier::Train(training, {});
  ASSERT_THAT(classifier, IsOk());
  const auto comparison = CompareExportsByDock(before_path, after_path, classifier->get());
  ASSERT_THAT(comparison, IsOk());
  int protrusions = 0;
  for (const ChangedRegion& region : comparison->new_regions) {
    std::printf("region %d: %.2f m², %s (p %.2f)\n", region.region.id, region.area_m2,
                region.predicted_class.c_str(), region.probability);
    EXPECT_TRUE(region.predicted_class == "protrusion" || region.predicted_class == "new_space");
    EXPECT_GE(region.probability, 0.0);
    EXPECT_LE(region.probability, 1.0);
    protrusions += region.predicted_class == "protrusion" ? 1 : 0;
  }
  const auto largest =
      std::max_element(comparison->new_regions.begin(), comparison->new_regions.end(),
                       [](const ChangedRegion& a, const ChangedRegion& b) { return a.area_m2 < b.area_m2; });
  ASSERT_NE(largest, comparison->new_regions.end());
  EXPECT_EQ(largest->predicted_class, "new_space") << largest->probability;
  std::printf("%zu training regions; %d of %zu new regions classed protrusion\n", training.size(),
              protrusions, comparison->new_regions.size());
}

/// The same real pair classed by the built-in default model (what fleetd uses when no model is active):
/// every region with its class and the features that decided it, printed for the README's account.
TEST(MapComparison, RealHomeRegionsClassedByTheDefaultModel) {
  TEST_DATA_FILE_OR_SKIP(before_path, "valetudo/dreame_d9_1058_no_segments.json");
  TEST_DATA_FILE_OR_SKIP(after_path, "valetudo/dreame_d9_1058_with_segments.json");
  const auto classifier = slamcore::DefaultProtrusionClassifier();
  ASSERT_THAT(classifier, IsOk());
  const auto comparison = CompareExportsByDock(before_path, after_path, classifier->get());
  ASSERT_THAT(comparison, IsOk());
  const auto& names = slamcore::ProtrusionFeatureNames();
  int protrusions = 0;
  for (const ChangedRegion& region : comparison->new_regions) {
    std::printf("region %d: %.2f m², %s (p %.2f):", region.region.id, region.area_m2,
                region.predicted_class.c_str(), region.probability);
    for (std::size_t f = 0; f < names.size(); ++f)
      std::printf(" %s=%.3g", names[f].c_str(), region.region.features[f]);
    std::printf("\n");
    protrusions += region.predicted_class == "protrusion" ? 1 : 0;
  }
  const auto largest =
      std::max_element(comparison->new_regions.begin(), comparison->new_regions.end(),
                       [](const ChangedRegion& a, const ChangedRegion& b) { return a.area_m2 < b.area_m2; });
  ASSERT_NE(largest, comparison->new_regions.end());
  EXPECT_NEAR(largest->area_m2, 13.75, 0.5);
  // What the default model calls these real changes is reported, not asserted: it calls most of them
  // protrusions (README "Protrusions", where it falls short).
  for (const ChangedRegion& region : comparison->new_regions) {
    EXPECT_TRUE(region.predicted_class == "protrusion" || region.predicted_class == "new_space");
    EXPECT_GE(region.probability, 0.0);
    EXPECT_LE(region.probability, 1.0);
  }
  std::printf("default model: %d of %zu new regions classed protrusion\n", protrusions,
              comparison->new_regions.size());
}

}  // namespace
}  // namespace analyzer
