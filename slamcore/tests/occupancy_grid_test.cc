// Occupancy grids: map_server PGM/YAML and PNG round trips on the real maps, refusal of bad files, and
// the renderer's rule that a ray stops at the wall the other patches agree on.
#include "slamcore/occupancy_grid.h"

#include "slamcore/mapper.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <utility>
#include <random>

#include "test_data.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

std::filesystem::path TempDir(const std::string& name) {
  const auto dir =
      std::filesystem::temp_directory_path() /
      ("slamcore_occ_" + name + "_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(OccupancyGridIo, ReadsEveryRealMapWithTheirPixelConvention) {
  // Every map of the widest set at hand: the larger set's 11 when it is there, else data/'s 5.
  const std::filesystem::path folder = test_data::WidestDir("maps");
  const int expected = folder == test_data::Sample() / "maps" ? 5 : 11;
  int maps = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.path().extension() != ".yaml") continue;
    auto grid = ReadMapServerYaml(entry.path().string());
    ASSERT_THAT(grid, IsOk());
    EXPECT_DOUBLE_EQ(grid->resolution, 0.05);
    EXPECT_GT(grid->CountCells(CellState::kFree), 1000) << entry.path();
    EXPECT_GT(grid->CountCells(CellState::kOccupied), 100) << entry.path();
    ++maps;
  }
  EXPECT_EQ(maps, expected) << folder;
}

TEST(OccupancyGridIo, LowerLeftOriginMeansImageRowsAreFlipped) {
  auto grid = OccupancyGrid::Create(3, 2, 0.1, 1.0, 2.0);
  ASSERT_THAT(grid, IsOk());
  grid->at(0, 0) = static_cast<std::int8_t>(CellState::kOccupied);  // lowest y: the image's bottom row
  const std::string pgm = EncodePgm(*grid);
  // Header then 6 pixels: the occupied one is the first pixel of the LAST image row.
  const std::string pixels = pgm.substr(pgm.size() - 6);
  EXPECT_EQ(static_cast<unsigned char>(pixels[3]), 0);
  EXPECT_EQ(static_cast<unsigned char>(pixels[0]), 205);
}

TEST(OccupancyGridIo, PgmAndPngRoundTripTheRealMaps) {
  const auto dir = TempDir("roundtrip");
  auto original = ReadMapServerYaml((test_data::Sample() / "maps/aws_small_house.yaml").string());
  ASSERT_THAT(original, IsOk());
  for (const bool png : {false, true}) {
    const auto yaml = dir / (png ? "png_map.yaml" : "pgm_map.yaml");
    ASSERT_THAT(WriteMapServerYaml(*original, yaml.string(), png), IsOk());
    auto back = ReadMapServerYaml(yaml.string());
    ASSERT_THAT(back, IsOk());
    EXPECT_EQ(back->cells, original->cells);
    EXPECT_EQ(back->width, original->width);
    EXPECT_DOUBLE_EQ(back->origin_x, original->origin_x);
    EXPECT_DOUBLE_EQ(back->origin_y, original->origin_y);
  }
  std::filesystem::remove_all(dir);
}

// The YAML keeps every number as it was (fixed decimals wrote a 1e-7 m resolution as 0, and a fixed
// buffer cut a long origin off), and a YAML named like its own image is refused instead of written over it.
TEST(OccupancyGridIo, YamlKeepsEveryNumberAndNeverReplacesItsImage) {
  const auto dir = TempDir("numbers");
  OccupancyGrid grid = *OccupancyGrid::Create(4, 3, 1e-7, -1e300, 123456.78901234567);
  grid.origin_yaw = 0.1;
  grid.at(1, 1) = static_cast<std::int8_t>(CellState::kFree);
  ASSERT_THAT(WriteMapServerYaml(grid, (dir / "map.yaml").string()), IsOk());
  auto back = ReadMapServerYaml((dir / "map.yaml").string());
  ASSERT_THAT(back, IsOk());
  EXPECT_EQ(back->resolution, grid.resolution);
  EXPECT_EQ(back->origin_x, grid.origin_x);
  EXPECT_EQ(back->origin_y, grid.origin_y);
  EXPECT_EQ(back->origin_yaw, grid.origin_yaw);
  EXPECT_EQ(back->cells, grid.cells);
  for (const bool png : {false, true}) {
    const auto image = dir / (png ? "map.png" : "map.pgm");
    const auto refused = WriteMapServerYaml(grid, image.string(), png);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.message().find("names the map's image"), std::string::npos) << refused.ToString();
  }
  // The image written above is intact, and no temporary file is left beside it.
  EXPECT_THAT(ReadMapServerYaml((dir / "map.yaml").string()), IsOk());
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    EXPECT_NE(entry.path().extension(), ".tmp") << entry.path();
  }
  std::filesystem::remove_all(dir);
}

TEST(OccupancyGridIo, RefusesCorruptPgmWithClearErrors) {
  auto check = [](const std::string& bytes, const std::string& expected) {
    auto grid = DecodePgm(bytes, 0.05, 0, 0);
    ASSERT_FALSE(grid.ok()) << "accepted: " << bytes.substr(0, 20);
    EXPECT_NE(grid.status().message().find(expected), std::string::npos) << grid.status().ToString();
  };
  check("", "magic");
  check("P6\n2 2\n255\n0000", "magic");
  check("P5\n2 x\n255\n0000", "height");
  check("P5\n2 2\n255\n00", "truncated");
  check("P5\n0 0\n255\n", "empty map");
  check("P5\n100000 100000\n255\n", "100000 x 100000 cells is wider or taller than the 20000");
  check("P5\n20000 20000\n255\n", "20000 x 20000 = 400000000 cells, more than the 100000000");
  check("P5\n2 2\n65535\n00000000", "maxval");
  check("P2\n2 2\n255\n1 2 3\n", "ASCII pixel 3");
  // A header promising 10⁸ pixels over 10 bytes is refused before 100 MB are allocated for the grid.
  check("P5\n20000 5000\n255\n" + std::string(10, '\xfe'),
        "truncated pixel data (10 bytes for 100000000 pixels)");
  check("P2\n20000 5000\n255\n0 0 0", "truncated pixel data");
  EXPECT_THAT(DecodePgm("P2\n# comment\n2 1\n255\n254 0\n", 0.05, 0, 0), IsOk());
}

TEST(OccupancyGridIo, YamlTextInMemoryReadsOnlyTheImageItsReaderGives) {
  const std::string pgm = "P5\n2 1\n255\n" + std::string("\xfe\x00", 2);
  std::string asked;
  const auto reader = [&](const std::string& name) -> Result<std::string> {
    asked = name;
    if (name != "map.pgm") return InvalidArgument("image \"" + name + "\" names a file outside the upload");
    return pgm;
  };
  auto grid = ParseMapServerYaml("image: \"map.pgm\"\nresolution: 0.05\norigin: [1.0, 2.0, 0.0]\n",
                                 "upload.yaml", reader);
  ASSERT_THAT(grid, IsOk());
  EXPECT_EQ(asked, "map.pgm");
  EXPECT_EQ(grid->width, 2);
  EXPECT_DOUBLE_EQ(grid->origin_y, 2.0);
  auto outside = ParseMapServerYaml("image: ../../etc/passwd\nresolution: 0.05\norigin: [0, 0, 0]\n",
                                    "upload.yaml", reader);
  ASSERT_THAT(outside, StatusIs(StatusCode::kInvalidArgument));
  EXPECT_NE(outside.status().message().find("outside the upload"), std::string::npos);
  auto broken =
      ParseMapServerYaml("image: map.pgm\nresolution: fine\norigin: [0, 0, 0]\n", "upload.yaml", reader);
  ASSERT_FALSE(broken.ok());
  EXPECT_NE(broken.status().message().find("upload.yaml: resolution is not a number"), std::string::npos);
  EXPECT_FALSE(ParseMapServerYaml(std::string(70000, '#'), "upload.yaml", reader).ok());
}

TEST(OccupancyGridIo, RefusesCorruptPngAndYamlWithClearErrors) {
  EXPECT_FALSE(DecodePng("not a png", 0.05, 0, 0).ok());
  auto grid = OccupancyGrid::Create(20, 10, 0.05);
  ASSERT_THAT(grid, IsOk());
  auto png = EncodePng(*grid);
  ASSERT_THAT(png, IsOk());
  std::string truncated = png->substr(0, png->size() / 2);
  auto decoded = DecodePng(truncated, 0.05, 0, 0);
  ASSERT_FALSE(decoded.ok());
  EXPECT_NE(decoded.status().message().find("corrupt"), std::string::npos) << decoded.status().ToString();
  std::string absurd = *png;
  absurd[16] = '\x7f';  // width 2^30: refused from the header, before any allocation
  decoded = DecodePng(absurd, 0.05, 0, 0);
  ASSERT_FALSE(decoded.ok());
  EXPECT_NE(decoded.status().message().find("20001 x 10 cells is wider or taller"), std::string::npos)
      << decoded.status().ToString();

  const auto dir = TempDir("yaml");
  auto write_yaml = [&](const std::string& text) {
    EXPECT_THAT(WriteFileBytes((dir / "m.yaml").string(), text), IsOk());
    return ReadMapServerYaml((dir / "m.yaml").string());
  };
  const std::string pgm("P5\n2 2\n255\n\xfe\xfe\x00\xcd", 15);
  ASSERT_THAT(WriteFileBytes((dir / "m.pgm").string(), pgm), IsOk());
  EXPECT_THAT(write_yaml("image: m.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"), IsOk());
  EXPECT_NE(
      write_yaml("resolution: 0.05\norigin: [0, 0, 0]\n").status().message().find("missing key 'image'"),
      std::string::npos);
  EXPECT_NE(
      write_yaml("image: m.pgm\nresolution: abc\norigin: [0, 0, 0]\n").status().message().find("resolution"),
      std::string::npos);
  EXPECT_NE(
      write_yaml("image: m.pgm\nresolution: -1\norigin: [0, 0, 0]\n").status().message().find("resolution"),
      std::string::npos);
  EXPECT_NE(write_yaml("image: m.pgm\nresolution: 0.05\norigin: [0, 0]\n").status().message().find("origin"),
            std::string::npos);
  EXPECT_EQ(write_yaml("image: nope.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").status().code(),
            StatusCode::kNotFound);
  std::filesystem::remove_all(dir);
}

/// A map of `nodes` nodes on a line, each with a 40×40 patch: free inside, a wall on one side.
Map MakeMap(int nodes) {
  Map map;
  for (int i = 0; i < nodes; ++i) {
    Node node;
    node.id = i;
    node.pose = SE2(0.5 * i, 0.1 * std::sin(i), 0.05 * i);
    EXPECT_THAT(map.graph.AddNode(node), IsOk());
    LocalMapEvent patch;
    patch.width = 40;
    patch.height = 40;
    patch.node_T_origin = SE2(-1.0, -1.0, 0.0);
    patch.cells.assign(40 * 40, 0);
    for (int col = 0; col < 40; ++col) patch.cells[static_cast<std::size_t>(39 * 40 + col)] = 100;
    for (int col = 0; col < 5; ++col) patch.cells[static_cast<std::size_t>(col)] = -1;
    map.local_maps.emplace(i, std::move(patch));
  }
  return map;
}

// A strip two cells high (y from -0.05 to 0.05) along +x from the node: free for 2 m, a wall at 2.00–2.05 m,
// unknown past it. Global cell centres fall mid-cell in it (rows at y = ±0.025), never on a cell's edge.
LocalMapEvent WallAhead() {
  LocalMapEvent patch;
  patch.width = 60;
  patch.height = 2;
  patch.node_T_origin = SE2(0.0, -0.05, 0.0);
  patch.cells.assign(120, -1);
  for (int row = 0; row < 2; ++row) {
    for (int col = 0; col < 40; ++col) patch.cells[static_cast<std::size_t>(row * 60 + col)] = 0;
    patch.cells[static_cast<std::size_t>(row * 60 + 40)] = 100;
  }
  return patch;
}

void AddPatchAt(Map* map, NodeId id, const SE2& pose, LocalMapEvent patch) {
  Node node;
  node.id = id;
  node.pose = pose;
  ASSERT_THAT(map->graph.AddNode(node), IsOk());
  map->local_maps.emplace(id, std::move(patch));
}

// The cell whose centre is at (x, 0.025) in the rendered grid.
std::int8_t CellAt(const OccupancyGrid& grid, double x) {
  return grid.at(static_cast<int>(std::floor((x - grid.origin_x) / grid.resolution)),
                 static_cast<int>(std::floor((0.025 - grid.origin_y) / grid.resolution)));
}

// Free and occupied cells in the row through y = 0.025.
std::pair<int, int> FreeAndOccupiedAlongTheRay(const OccupancyGrid& grid) {
  const int row = static_cast<int>(std::floor((0.025 - grid.origin_y) / grid.resolution));
  int free = 0, occupied = 0;
  for (int col = 0; col < grid.width; ++col) {
    free += grid.at(col, row) == static_cast<std::int8_t>(CellState::kFree);
    occupied += grid.at(col, row) == static_cast<std::int8_t>(CellState::kOccupied);
  }
  return {free, occupied};
}

TEST(OccupancyGridRender, APatchsRaysStopAtTheWallTheOtherPatchesAgreeOn) {
  // Two patches from the node at the origin see the wall at 2.00–2.05 m; a third, from a node placed 0.5 m
  // too far along the ray, claims free floor up to 2.5 m and its own wall at 2.50–2.55 m.
  Map map;
  AddPatchAt(&map, 0, SE2(0, 0, 0), WallAhead());
  AddPatchAt(&map, 1, SE2(0, 0, 0), WallAhead());
  AddPatchAt(&map, 2, SE2(0.5, 0, 0), WallAhead());
  GlobalGridRenderer renderer;
  ASSERT_THAT(renderer.RenderAll(map), IsOk());
  const OccupancyGrid& grid = renderer.grid();
  constexpr auto kFree = static_cast<std::int8_t>(CellState::kFree);
  constexpr auto kOccupied = static_cast<std::int8_t>(CellState::kOccupied);
  constexpr auto kUnknown = static_cast<std::int8_t>(CellState::kUnknown);
  // The wall: 2 occupied votes against 1 free. The third patch crossed it 1.525 m from its node, so its
  // votes farther than 1.525 + 2.5 × 0.05 = 1.65 m (cell centres from 2.175 m on) are withdrawn: 40 free cells
  // before the wall, 2 past it within the tolerance, 1 wall cell; its 7 free cells and its wall beyond, unknown.
  EXPECT_EQ(CellAt(grid, 2.025), kOccupied);
  EXPECT_EQ(CellAt(grid, 2.075), kFree);
  EXPECT_EQ(CellAt(grid, 2.125), kFree);
  EXPECT_EQ(CellAt(grid, 2.175), kUnknown);
  EXPECT_EQ(CellAt(grid, 2.475), kUnknown);
  EXPECT_EQ(CellAt(grid, 2.525), kUnknown);
  EXPECT_EQ(FreeAndOccupiedAlongTheRay(grid), std::make_pair(42, 1));

  // Space past the wall that a patch from the other side saw stays free: only the crossing patch's votes go.
  AddPatchAt(&map, 3, SE2(4.05, 0, std::numbers::pi), WallAhead());  // its wall the same cell
  ASSERT_THAT(renderer.RenderAll(map), IsOk());
  EXPECT_EQ(CellAt(renderer.grid(), 2.275), kFree);
  EXPECT_EQ(CellAt(renderer.grid(), 2.525), kFree);
}

TEST(OccupancyGridRender, OnePatchsWallDoesNotStopAnothersRays) {
  // One vote is no agreement: with one patch at the true node and one 0.5 m along, both walls stand (each
  // one occupied vote against at most one free) and the farther patch's 9 free cells past 2.05 m count.
  Map map;
  AddPatchAt(&map, 0, SE2(0, 0, 0), WallAhead());
  AddPatchAt(&map, 1, SE2(0.5, 0, 0), WallAhead());
  GlobalGridRenderer renderer;
  ASSERT_THAT(renderer.RenderAll(map), IsOk());
  EXPECT_EQ(FreeAndOccupiedAlongTheRay(renderer.grid()), std::make_pair(40 + 9, 2));
}

TEST(OccupancyGridRender, TheRenderDoesNotDependOnThePatchesOrder) {
  Map map = MakeMap(30);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  for (NodeId node = 0; node < 30; node += 2) {  // half the patches misplaced: many rays cross agreed walls
    const SE2 pose = map.graph.node(node).pose;
    map.graph.mutable_node(node).pose =
        SE2(pose.x() + jitter(random), pose.y() + jitter(random), pose.theta());
  }
  GlobalGridRenderer forward;
  ASSERT_THAT(forward.RenderAll(map), IsOk());
  // The same map with the node ids reversed, so the patches are visited in the other order.
  Map reversed;
  for (NodeId node = 0; node < 30; ++node) {
    AddPatchAt(&reversed, 29 - node, map.graph.node(node).pose, map.local_maps.at(node));
  }
  GlobalGridRenderer backward;
  ASSERT_THAT(backward.RenderAll(reversed), IsOk());
  EXPECT_EQ(forward.grid().cells, backward.grid().cells);
  EXPECT_GT(forward.grid().CountCells(CellState::kOccupied), 0);
}

TEST(OccupancyGridRender, RefusesBadPatchesAndAbsurdExtents) {
  Map map = MakeMap(2);
  map.local_maps[1].cells.pop_back();
  GlobalGridRenderer renderer;
  EXPECT_FALSE(renderer.RenderAll(map).ok());
  map = MakeMap(2);
  map.graph.mutable_node(1).pose = SE2(1e7, 0, 0);
  const Status status = renderer.RenderAll(map);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("absurd"), std::string::npos);
  EXPECT_FALSE(renderer.RenderAll(Map{}).ok());
}

}  // namespace
}  // namespace slamcore
