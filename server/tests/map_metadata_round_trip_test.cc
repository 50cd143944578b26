// The metadata of imported Valetudo maps through the whole loop on a real SQLite file: every export is
// imported (MapHistory::Import, stored with its version), handed back (Export "valetudo") and imported again,
// and must come back with the same grid, rooms (id, name, pixels), zones, virtual walls, paths and poses.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "analyzer/map_metadata.h"
#include "server/map_history.h"
#include "sqlite_repository_test.h"
#include "test_data.h"

namespace server {
namespace {

class MetadataRoundTrip : public SqliteRepositoryTest {
 protected:
  /// Round-trips every export of `folder`; returns how many files it checked.
  int RoundTripFolder(const std::filesystem::path& folder) {
    MapHistory history(*repository_, MapPolicy{});
    int files = 0;
    for (const auto& entry : std::filesystem::directory_iterator(folder)) {
      if (entry.path().extension() != ".json") continue;
      SCOPED_TRACE(entry.path().filename().string());
      const std::string robot = "home-" + std::to_string(++files);  // one robot each: no comparison needed
      const auto original = analyzer::ReadValetudoMap(entry.path().string());
      if (!original.ok()) {
        ADD_FAILURE() << original.status().ToString();
        continue;
      }
      const analyzer::ImportedMap imported = analyzer::ImportValetudo(*original);
      auto version = history.Import(robot, imported.snapshot, imported.metadata,
                                    "valetudo:" + entry.path().filename().string(), "", true, "engineer:e");
      if (!version.ok()) {
        ADD_FAILURE() << version.status().ToString();
        continue;
      }
      auto files_back = history.Export(robot, version->version(), "valetudo");
      if (!files_back.ok() || files_back->size() != 1) {
        ADD_FAILURE() << files_back.status().ToString();
        continue;
      }
      const auto back = analyzer::ParseValetudoMap(files_back->front().content(), "hand-back.json");
      if (!back.ok()) {
        ADD_FAILURE() << back.status().ToString();
        continue;
      }
      ExpectSame(*original, *back);
    }
    return files;
  }

  static void ExpectShapes(const std::vector<analyzer::ValetudoShape>& original,
                           const std::vector<analyzer::ValetudoShape>& back, const char* what) {
    ASSERT_EQ(back.size(), original.size()) << what;
    for (std::size_t i = 0; i < original.size(); ++i) {
      EXPECT_EQ(back[i].type, original[i].type) << what << " " << i;
      ASSERT_EQ(back[i].points.size(), original[i].points.size()) << what << " " << i;
      for (std::size_t k = 0; k < original[i].points.size(); ++k) {
        EXPECT_NEAR((back[i].points[k] - original[i].points[k]).norm(), 0.0, 0.006)
            << what << " " << i << "." << k;
      }
    }
  }

  static void ExpectPose(const std::optional<analyzer::ValetudoPose>& original,
                         const std::optional<analyzer::ValetudoPose>& back, const char* what) {
    ASSERT_EQ(back.has_value(), original.has_value()) << what;
    if (!original) return;
    EXPECT_NEAR(back->pose.x(), original->pose.x(), 0.006) << what;
    EXPECT_NEAR(back->pose.y(), original->pose.y(), 0.006) << what;
    EXPECT_EQ(back->has_angle, original->has_angle) << what;
    if (original->has_angle) {
      EXPECT_NEAR(std::remainder(back->pose.theta() - original->pose.theta(), 2 * M_PI), 0.0, 0.01) << what;
    }
  }

  static void ExpectSame(const analyzer::ValetudoMap& original, const analyzer::ValetudoMap& back) {
    EXPECT_EQ(back.grid.width, original.grid.width);
    EXPECT_EQ(back.grid.height, original.grid.height);
    EXPECT_TRUE(back.grid.cells == original.grid.cells);
    std::vector<const analyzer::ValetudoLayer*> rooms, rooms_back;
    for (const auto& layer : original.layers) {
      if (layer.type == "segment") rooms.push_back(&layer);
    }
    for (const auto& layer : back.layers) {
      if (layer.type == "segment") rooms_back.push_back(&layer);
    }
    ASSERT_EQ(rooms_back.size(), rooms.size());
    for (std::size_t i = 0; i < rooms.size(); ++i) {
      EXPECT_EQ(rooms_back[i]->segment_id, rooms[i]->segment_id);
      EXPECT_EQ(rooms_back[i]->name, rooms[i]->name);
      EXPECT_EQ(rooms_back[i]->pixel_count, rooms[i]->pixel_count) << "room " << rooms[i]->segment_id;
      EXPECT_EQ(rooms_back[i]->runs, rooms[i]->runs) << "room " << rooms[i]->segment_id;
    }
    ExpectShapes(original.zones, back.zones, "zones");
    ExpectShapes(original.virtual_walls, back.virtual_walls, "virtual walls");
    ExpectShapes(original.paths, back.paths, "paths");
    ExpectPose(original.robot, back.robot, "robot");
    ExpectPose(original.dock, back.dock, "dock");
    ASSERT_EQ(back.other_points.size(), original.other_points.size());
    for (std::size_t i = 0; i < original.other_points.size(); ++i) {
      EXPECT_EQ(back.other_points[i].type, original.other_points[i].type);
    }
  }
};

TEST_F(MetadataRoundTrip, EveryExportInTheSampleComesBackWithItsRoomsZonesWallsAndPoses) {
  EXPECT_EQ(RoundTripFolder(test_data::Sample() / "valetudo"), 5);
}

TEST_F(MetadataRoundTrip, EveryExportInTheLargerSetComesBackWithItsRoomsZonesWallsAndPoses) {
  const auto larger = test_data::Larger();
  if (!larger || !std::filesystem::is_directory(*larger / "valetudo")) {
    GTEST_SKIP() << test_data::NeedsLargerSet("valetudo/ (24 exports)");
  }
  EXPECT_GE(RoundTripFolder(*larger / "valetudo"), 20);
}

}  // namespace
}  // namespace server
