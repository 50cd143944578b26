#include "sim/world.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "test_data.h"
#include "status_matchers.h"

namespace sim {
namespace {

const std::filesystem::path kData = test_data::Sample();

TEST(WorldTest, FloorPlanBecomesAHomeAtApartmentScale) {
  // The first 20 plans of the widest set at hand (data/ carries 16, the larger set 240).
  const auto worlds = ListWorlds(test_data::WidestDir("floorplans"));
  ASSERT_THAT(worlds, IsOk());
  ASSERT_GE(worlds->size(), 16u);
  const std::size_t tried = std::min<std::size_t>(20, worlds->size());
  int loaded = 0;
  for (std::size_t k = 0; k < tried; ++k) {
    const auto world = LoadWorld((*worlds)[k], 7);
    if (!world.ok()) continue;  // a few annotations have no room label inside their walls
    ++loaded;
    const double width_m = world->grid.width() * world->grid.resolution();
    const double height_m = world->grid.height() * world->grid.resolution();
    EXPECT_GT(std::max(width_m, height_m), 4.0) << (*worlds)[k];
    EXPECT_LT(std::max(width_m, height_m), 30.0) << (*worlds)[k];
    EXPECT_FALSE(world->rooms.empty());
    EXPECT_GE(world->landmarks.size(), 4u);
    EXPECT_TRUE(world->grid.DiscIsFree(world->dock.translation(), 0.17)) << (*worlds)[k];
  }
  EXPECT_GE(4 * loaded, 3 * static_cast<int>(tried)) << loaded << " of " << tried << " plans loaded";
}

TEST(WorldTest, SameSeedGivesTheSameHome) {
  const auto path = *ListWorlds(kData / "floorplans")->begin();
  const auto a = LoadWorld(path, 3), b = LoadWorld(path, 3);
  ASSERT_THAT(a, IsOk());
  ASSERT_THAT(b, IsOk());
  ASSERT_EQ(a->landmarks.size(), b->landmarks.size());
  for (std::size_t k = 0; k < a->landmarks.size(); ++k) {
    EXPECT_EQ(a->landmarks[k].pose.vector(), b->landmarks[k].pose.vector());
    EXPECT_EQ(a->landmarks[k].appearance, b->landmarks[k].appearance);
  }
}

TEST(WorldTest, HomesHaveSymmetricFurnitureAndLookAlikes) {
  const auto path = *ListWorlds(kData / "floorplans")->begin();
  const auto world = LoadWorld(path, 1);
  ASSERT_THAT(world, IsOk());
  int symmetric = 0;
  std::map<int, int> appearance_count;
  for (const Landmark& landmark : world->landmarks) {
    if (landmark.symmetric) ++symmetric;
    ++appearance_count[landmark.appearance];
  }
  EXPECT_GE(symmetric, 1);
  EXPECT_TRUE(std::any_of(appearance_count.begin(), appearance_count.end(),
                          [](const auto& entry) { return entry.second >= 2; }));
}

TEST(WorldTest, RobotVacuumMapBecomesAHome) {
  const auto world = LoadWorld(kData / "maps/valetudo_dreame_d9_1058_with_segments.yaml", 1);
  ASSERT_THAT(world, IsOk());
  EXPECT_GE(world->rooms.size(), 2u);
  EXPECT_GE(world->landmarks.size(), 4u);
  EXPECT_TRUE(world->grid.DiscIsFree(world->dock.translation(), 0.17));
}

TEST(WorldTest, RayCastingStopsAtWalls) {
  Grid grid(40, 40, 0.05, Vector2::Zero(), Cell::kFree);
  for (int j = 0; j < 40; ++j) grid.set(30, j, Cell::kOccupied);  // a wall at x = 1.5 m
  EXPECT_NEAR(grid.CastRay(Vector2(0.5, 1.0), 0.0, 5.0), 1.0, 0.03);
  EXPECT_FALSE(grid.LineOfSight(Vector2(0.5, 1.0), Vector2(1.8, 1.0)));
  EXPECT_TRUE(grid.LineOfSight(Vector2(0.5, 1.0), Vector2(1.2, 0.2)));
}

TEST(WorldTest, BadHomeFilesAreRefused) {
  const std::filesystem::path directory = ::testing::TempDir();
  std::ofstream(directory / "broken.txt") << "10 20 abc 40 wall 1 1\n";
  const auto broken = LoadWorld(directory / "broken.txt", 1);
  ASSERT_FALSE(broken.ok());
  EXPECT_NE(broken.status().message().find("broken.txt:1"), std::string::npos) << broken.status().message();
  EXPECT_FALSE(LoadWorld(directory / "home.obj", 1).ok());
  EXPECT_EQ(ListWorlds(directory / "missing").status().code(), slamcore::StatusCode::kNotFound);
}

}  // namespace
}  // namespace sim
