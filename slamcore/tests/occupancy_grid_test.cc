// Occupancy grids: map_server PGM/YAML and PNG round trips on the real maps, refusal of bad files, and
// the incremental renderer equal to a render from scratch.
#include "slamcore/occupancy_grid.h"

#include "slamcore/mapper.h"

#include <gtest/gtest.h>

#include <filesystem>
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
  check("P5\n100000 100000\n255\n", "absurd");
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
  EXPECT_NE(decoded.status().message().find("absurd"), std::string::npos) << decoded.status().ToString();

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

/// Whether two grids hold the same cells at the same world positions (bounds may differ; a cell outside
/// one grid counts as unknown).
void ExpectSameWorldCells(const OccupancyGrid& a, const OccupancyGrid& b) {
  ASSERT_DOUBLE_EQ(a.resolution, b.resolution);
  const long dx = std::lround((b.origin_x - a.origin_x) / a.resolution);
  const long dy = std::lround((b.origin_y - a.origin_y) / a.resolution);
  int differences = 0;
  for (int row = 0; row < a.height; ++row) {
    for (int col = 0; col < a.width; ++col) {
      const int bc = static_cast<int>(col - dx), br = static_cast<int>(row - dy);
      const std::int8_t other = b.InBounds(bc, br) ? b.at(bc, br) : std::int8_t{-1};
      differences += a.at(col, row) != other;
    }
  }
  EXPECT_EQ(differences, 0);
  EXPECT_EQ(a.CountCells(CellState::kOccupied), b.CountCells(CellState::kOccupied));
  EXPECT_EQ(a.CountCells(CellState::kFree), b.CountCells(CellState::kFree));
}

TEST(OccupancyGridRender, IncrementalUpdateEqualsRenderFromScratch) {
  Map map = MakeMap(30);
  GlobalGridRenderer incremental;
  ASSERT_THAT(incremental.RenderAll(map), IsOk());
  EXPECT_GT(incremental.grid().CountCells(CellState::kOccupied), 0);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  for (int step = 0; step < 10; ++step) {
    const NodeId moved = static_cast<NodeId>(random() % 30);
    const SE2 old = map.graph.node(moved).pose;
    map.graph.mutable_node(moved).pose =
        SE2(old.x() + jitter(random), old.y() + jitter(random), old.theta() + 0.2);
    int rerendered = 0;
    ASSERT_THAT(incremental.Update(map, &rerendered), IsOk());
    EXPECT_EQ(rerendered, 1);
    GlobalGridRenderer scratch;
    ASSERT_THAT(scratch.RenderAll(map), IsOk());
    SCOPED_TRACE(step);
    ExpectSameWorldCells(incremental.grid(), scratch.grid());
  }
}

TEST(OccupancyGridRender, GrowsBoundsAndDropsRemovedPatches) {
  Map map = MakeMap(5);
  GlobalGridRenderer renderer;
  ASSERT_THAT(renderer.RenderAll(map), IsOk());
  map.graph.mutable_node(2).pose = SE2(40.0, -30.0, 1.0);  // far outside: the bounds must grow
  ASSERT_THAT(renderer.Update(map), IsOk());
  GlobalGridRenderer scratch;
  ASSERT_THAT(scratch.RenderAll(map), IsOk());
  ExpectSameWorldCells(renderer.grid(), scratch.grid());
  map.local_maps.erase(3);
  ASSERT_THAT(renderer.Update(map), IsOk());
  ASSERT_THAT(scratch.RenderAll(map), IsOk());
  ExpectSameWorldCells(renderer.grid(), scratch.grid());
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

TEST(OccupancyGridRender, CountsTheKnownCellsOfTheRenderWithoutRenderingIt) {
  Map map = MakeMap(30);
  std::mt19937 random(11);
  std::uniform_real_distribution<double> heading(-3.1, 3.1);
  for (NodeId node = 0; node < 30; node += 3) {  // rotated patches, whose bounding boxes hold cells they miss
    const SE2 pose = map.graph.node(node).pose;
    map.graph.mutable_node(node).pose = SE2(pose.x(), pose.y(), heading(random));
  }
  map.local_maps[4].cells.assign(40 * 40, -1);    // a patch of unknown cells only votes nowhere
  map.local_maps.emplace(99, map.local_maps[0]);  // a patch of a node the graph does not hold is no part
  for (const Map& tried : {map, MakeMap(1)}) {
    GlobalGridRenderer renderer;
    ASSERT_THAT(renderer.RenderAll(tried), IsOk());
    const OccupancyGrid& grid = renderer.grid();
    const std::int64_t known =
        static_cast<std::int64_t>(grid.cells.size()) - grid.CountCells(CellState::kUnknown);
    EXPECT_GT(known, 0);
    const auto counted = GlobalGridRenderer().CountKnownCells(tried);
    ASSERT_THAT(counted, IsOk());
    EXPECT_EQ(*counted, known);
  }
  map.graph.mutable_node(1).pose = SE2(1e7, 0, 0);
  EXPECT_FALSE(GlobalGridRenderer().CountKnownCells(map).ok()) << "the same bounds as RenderAll's";
  EXPECT_FALSE(GlobalGridRenderer().CountKnownCells(Map{}).ok());
}

}  // namespace
}  // namespace slamcore
