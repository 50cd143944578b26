// ValetudoMap import (docs/formats/valetudo.md): every real export imports with per-layer areas equal to the
// file's own metaData.area, the grid equals the map_server conversion of the same export in data/maps, both
// pixel encodings, both metaData versions and zlib-deflated input give the same map, and malformed input is
// refused with an error naming the field.
#include "analyzer/valetudo_map.h"

#include "analyzer/map_metadata.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <limits>

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>
#include <utility>

#include "test_data.h"
#include "status_matchers.h"

namespace analyzer {
namespace {

using json = nlohmann::json;

std::string ReadText(const std::filesystem::path& path) {
  auto bytes = slamcore::ReadFileBytes(path.string());
  EXPECT_THAT(bytes, IsOk());
  return bytes.ok() ? *bytes : std::string();
}

json ReadJson(const std::filesystem::path& path) { return json::parse(ReadText(path)); }

/// Counts, straight from the JSON, the pixels that are floor or segment but not wall, and the wall pixels.
std::pair<std::int64_t, std::int64_t> FreeAndWallPixels(const json& map) {
  std::set<std::pair<int, int>> free, walls;
  for (const json& layer : map["layers"]) {
    std::set<std::pair<int, int>>& target = layer["type"] == "wall" ? walls : free;
    if (layer.contains("compressedPixels") && !layer["compressedPixels"].empty()) {
      const json& runs = layer["compressedPixels"];
      for (std::size_t i = 0; i < runs.size(); i += 3) {
        for (int k = 0; k < runs[i + 2].get<int>(); ++k)
          target.insert({runs[i].get<int>() + k, runs[i + 1].get<int>()});
      }
    } else {
      const json& pixels = layer["pixels"];
      for (std::size_t i = 0; i < pixels.size(); i += 2)
        target.insert({pixels[i].get<int>(), pixels[i + 1].get<int>()});
    }
  }
  std::int64_t free_only = 0;
  for (const auto& pixel : free) free_only += walls.contains(pixel) ? 0 : 1;
  return {free_only, static_cast<std::int64_t>(walls.size())};
}

/// Imports every export in `folder` and checks each layer's area against the file's metaData.
int CheckEveryExport(const std::filesystem::path& folder) {
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().filename().string());
    ++files;
    const auto map = ReadValetudoMap(entry.path().string());
    EXPECT_THAT(map, IsOk());
    if (!map.ok()) continue;
    EXPECT_EQ(map->pixel_size_cm, 5);
    std::int64_t total = 0;
    int declared = 0;
    for (const ValetudoLayer& layer : map->layers) {
      EXPECT_GT(layer.pixel_count, 0) << layer.type;
      EXPECT_EQ(layer.area_cm2, layer.pixel_count * 25);  // pixelSize 5 cm: one pixel is 25 cm²
      if (layer.declared_area_cm2) {
        ++declared;
        EXPECT_EQ(layer.area_cm2, *layer.declared_area_cm2) << layer.type << " " << layer.segment_id;
      }
      total += layer.area_cm2;
    }
    EXPECT_GT(declared, 0) << "no layer declares its area";
    if (map->declared_total_area_cm2) {
      EXPECT_EQ(total, *map->declared_total_area_cm2);
    }
    // The grid holds exactly the layers' pixels: occupied = walls, free = (floor ∪ segments) \ walls. Some
    // exports' floor and segment layers overlap, so the free count comes from the file's pixels directly.
    EXPECT_EQ(map->grid.resolution, 0.05);
    const auto [free_pixels, wall_pixels] = FreeAndWallPixels(ReadJson(entry.path()));
    EXPECT_EQ(map->grid.CountCells(slamcore::CellState::kOccupied), wall_pixels);
    EXPECT_EQ(map->AreaOf("wall"), wall_pixels * 25);
    EXPECT_EQ(map->grid.CountCells(slamcore::CellState::kFree), free_pixels);
    EXPECT_TRUE(map->robot.has_value());
  }
  return files;
}

TEST(ValetudoMapTest, EveryCarriedExportImportsWithTheFilesOwnAreas) {
  EXPECT_EQ(CheckEveryExport(test_data::Sample() / "valetudo"), 5);
}

TEST(ValetudoMapTest, EveryExportOfTheLargerSetImportsWithTheFilesOwnAreas) {
  REQUIRE_LARGER_DATA_OR_SKIP("its 24 Valetudo exports (valetudo/), 19 of which data/ does not carry");
  EXPECT_EQ(CheckEveryExport(*test_data::Larger() / "valetudo"), 24);
}

TEST(ValetudoMapTest, GridEqualsTheMapServerConversionOfTheSameExport) {
  // data/maps holds these two exports converted to PGM/YAML (data/maps/SOURCES.md): same cells, same frame.
  for (const char* name : {"dreame_d9_1058_no_segments", "dreame_d9_1058_with_segments"}) {
    SCOPED_TRACE(name);
    const auto map =
        ReadValetudoMap((test_data::Sample() / "valetudo" / (std::string(name) + ".json")).string());
    ASSERT_THAT(map, IsOk());
    const auto converted = slamcore::ReadMapServerYaml(
        (test_data::Sample() / "maps" / ("valetudo_" + std::string(name) + ".yaml")).string());
    ASSERT_THAT(converted, IsOk());
    EXPECT_EQ(map->grid.width, converted->width);
    EXPECT_EQ(map->grid.height, converted->height);
    EXPECT_NEAR(map->grid.origin_x, converted->origin_x, 1e-9);
    EXPECT_NEAR(map->grid.origin_y, converted->origin_y, 1e-9);
    EXPECT_TRUE(map->grid.cells == converted->cells);
  }
}

TEST(ValetudoMapTest, EntitiesBecomePosesWallsAndZonesInMetres) {
  const auto map = ReadValetudoMap(
      (test_data::Sample() / "valetudo/dreame_1c_1096_virtualwall_and_forbidden_zone.json").string());
  ASSERT_THAT(map, IsOk());
  // robot_position [3250, 3203] cm, angle 90°; charger_location [3340, 3220] cm, angle 228°.
  ASSERT_TRUE(map->robot && map->dock);
  EXPECT_NEAR(map->robot->pose.x(), 32.50, 1e-9);
  EXPECT_NEAR(map->robot->pose.y(), -32.03, 1e-9);
  EXPECT_NEAR(map->robot->pose.theta(), -std::numbers::pi / 2, 1e-9);
  EXPECT_NEAR(map->dock->pose.translation().x(), 33.40, 1e-9);
  EXPECT_TRUE(map->dock->has_angle);
  ASSERT_EQ(map->virtual_walls.size(), 1u);
  ASSERT_EQ(map->virtual_walls[0].points.size(), 2u);
  EXPECT_NEAR(map->virtual_walls[0].points[1].x(), 34.25, 1e-9);
  EXPECT_NEAR(map->virtual_walls[0].points[1].y(), -33.06, 1e-9);
  ASSERT_EQ(map->zones.size(), 1u);
  EXPECT_EQ(map->zones[0].type, "no_go_area");
  EXPECT_EQ(map->zones[0].points.size(), 4u);
  ASSERT_EQ(map->paths.size(), 1u);
  EXPECT_EQ(map->paths[0].points.size(), 11u);
  // Rooms: three segments with their ids; the dock lies inside the mapped (free) area.
  std::vector<std::string> segments;
  for (const ValetudoLayer& layer : map->layers) {
    if (layer.type == "segment") segments.push_back(layer.segment_id);
  }
  EXPECT_EQ(segments, (std::vector<std::string>{"1", "2", "3"}));
}

/// The export rewritten as metaData version 1 with every layer's pixels expanded ([x, y, ...]), as Valetudo's
/// UI export and older versions write it, and with a room name.
json ExpandedVersion1(json map) {
  map["metaData"] = {{"version", 1}};
  for (json& layer : map["layers"]) {
    json pixels = json::array();
    const json& runs = layer["compressedPixels"];
    for (std::size_t i = 0; i < runs.size(); i += 3) {
      for (int k = 0; k < runs[i + 2].get<int>(); ++k) {
        pixels.push_back(runs[i].get<int>() + k);
        pixels.push_back(runs[i + 1]);
      }
    }
    layer.erase("compressedPixels");
    layer["pixels"] = pixels;
    if (layer["type"] == "segment" && layer["metaData"]["segmentId"] == "2")
      layer["metaData"]["name"] = "Küche";
  }
  return map;
}

TEST(ValetudoMapTest, ExpandedPixelsAndVersion1GiveTheSameMap) {
  const auto path = test_data::Sample() / "valetudo/roborock_S5_FW2008_with_segments.json";
  const auto compressed = ReadValetudoMap(path.string());
  ASSERT_THAT(compressed, IsOk());
  const auto expanded = ParseValetudoMap(ExpandedVersion1(ReadJson(path)).dump(), "expanded");
  ASSERT_THAT(expanded, IsOk());
  EXPECT_EQ(compressed->version, 2);
  EXPECT_EQ(expanded->version, 1);
  EXPECT_TRUE(expanded->grid.cells == compressed->grid.cells);
  ASSERT_EQ(expanded->layers.size(), compressed->layers.size());
  for (std::size_t k = 0; k < expanded->layers.size(); ++k) {
    EXPECT_EQ(expanded->layers[k].area_cm2, compressed->layers[k].area_cm2);
  }
  EXPECT_EQ(expanded->layers[3].name, "Küche");
}

TEST(ValetudoMapTest, Version1ExportOfTheLargerSetHasNamedRooms) {
  TEST_DATA_FILE_OR_SKIP(path, "valetudo/dreame_d9_1093_multi_map.json");
  const auto map = ReadValetudoMap(path.string());
  ASSERT_THAT(map, IsOk());
  EXPECT_EQ(map->version, 1);
  std::vector<std::string> names;
  for (const ValetudoLayer& layer : map->layers) {
    if (!layer.name.empty()) names.push_back(layer.name);
  }
  EXPECT_EQ(names, std::vector<std::string>{"Flur"});
  EXPECT_EQ(map->AreaOf("segment"), 27225 + 53400 + 47375 + 105500 + 99100 + 94775 + 12725);
}

std::string Deflate(const std::string& text) {
  uLongf size = compressBound(static_cast<uLong>(text.size()));
  std::string out(size, '\0');
  EXPECT_EQ(compress2(reinterpret_cast<Bytef*>(out.data()), &size,
                      reinterpret_cast<const Bytef*>(text.data()), static_cast<uLong>(text.size()), 9),
            Z_OK);
  out.resize(size);
  return out;
}

TEST(ValetudoMapTest, ZlibDeflatedExportAsPublishedOverMqttImports) {
  const auto path = test_data::Sample() / "valetudo/dreame_d9_1058_with_segments.json";
  const auto plain = ReadValetudoMap(path.string());
  ASSERT_THAT(plain, IsOk());
  const std::string deflated = Deflate(ReadText(path));
  const auto inflated = ParseValetudoMap(deflated, "mqtt");
  ASSERT_THAT(inflated, IsOk());
  EXPECT_TRUE(inflated->grid.cells == plain->grid.cells);
  EXPECT_EQ(inflated->AreaOf("segment"), plain->AreaOf("segment"));

  const auto truncated = ParseValetudoMap(deflated.substr(0, deflated.size() / 2), "mqtt");
  ASSERT_FALSE(truncated.ok());
  EXPECT_NE(truncated.status().message().find("zlib stream is corrupt or truncated"), std::string::npos)
      << truncated.status().ToString();
  ValetudoLimits small;
  small.max_inflated_bytes = 1000;  // a deflate bomb is cut off at the limit
  const auto bomb = ParseValetudoMap(deflated, "mqtt", small);
  ASSERT_FALSE(bomb.ok());
  EXPECT_NE(bomb.status().message().find("inflates to more than 1000 bytes"), std::string::npos);
}

// Within the byte limits a text can still cost gigabytes as a document (268 MB of "0," inflated from a
// 260 kB download): values and nesting are counted first, and the count stops at the bound.
TEST(ValetudoMapTest, TextsThatWouldTakeGigabytesAsADocumentAreRefusedByTheirShape) {
  const auto path = test_data::Sample() / "valetudo/dreame_d9_1058_with_segments.json";
  const std::string real = ReadText(path);
  ValetudoLimits tight;
  tight.max_json_values = 1000;
  auto refused = ParseValetudoMap(real, "export", tight);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("holds more than 1000 JSON values"), std::string::npos)
      << refused.status().ToString();
  // The real export is within the defaults, deflated or not.
  ASSERT_THAT(ParseValetudoMap(real, "export"), IsOk());
  ASSERT_THAT(ParseValetudoMap(Deflate(real), "export"), IsOk());
  // A million levels: the document parser would build them all before the import could say no.
  const std::string deep = std::string(1'000'000, '[') + std::string(1'000'000, ']');
  refused = ParseValetudoMap(Deflate(deep), "export");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("nests deeper than 64 levels"), std::string::npos)
      << refused.status().ToString();
}

// A few hundred bytes may describe far more than they hold: two pixels in opposite corners of a 20,000-pixel
// map span a grid of 4·10⁸ cells, and a run of three numbers covers up to 20,000 pixels. Both are bounded
// before the memory is taken, by the grid's span and by the pixels of all layers together.
TEST(ValetudoMapTest, SmallTextsThatDescribeHugeMapsAreRefusedByWhatTheyWouldCost) {
  const auto map_of = [](int side, json layers) {
    return json{{"__class", "ValetudoMap"},           {"metaData", {{"version", 2}}},
                {"size", {{"x", side}, {"y", side}}}, {"pixelSize", 5},
                {"layers", std::move(layers)},        {"entities", json::array()}}
        .dump();
  };
  const auto floor = [](json runs) { return json{{"type", "floor"}, {"compressedPixels", std::move(runs)}}; };
  const auto expect_refused_naming = [](const std::string& text, const ValetudoLimits& limits,
                                        const std::string& naming) {
    const auto refused = ParseValetudoMap(text, "export.json", limits);
    ASSERT_THAT(refused, StatusIs(slamcore::StatusCode::kInvalidArgument));
    EXPECT_NE(refused.status().message().find("export.json: " + naming), std::string::npos)
        << refused.status().message();
  };
  // Pixels (0, 0) and (2999, 2999): 3000 × 3000 pixels, 3020 × 3020 = 9,120,400 cells with the 10-cell margin.
  const std::string corners = map_of(3000, json::array({floor({0, 0, 1, 2999, 2999, 1})}));
  ValetudoLimits limits;
  limits.max_grid_cells = 9'120'399;
  expect_refused_naming(corners, limits,
                        "layers: their pixels span 3000 x 3000 map pixels, a grid of 9120400 cells with the "
                        "margin, more than the 9120399");
  limits.max_grid_cells = 9'120'400;
  const auto accepted = ParseValetudoMap(corners, "export.json", limits);
  ASSERT_THAT(accepted, IsOk());
  EXPECT_EQ(accepted->grid.width, 3020);
  EXPECT_EQ(accepted->grid.height, 3020);

  // Three layers of two full rows each (2 × 1000 pixels), against 5000 pixels for all layers: the third
  // layer is refused at its second row (4000 + 1000 covered, the next 1000 past what was left).
  json rows = json::array();
  for (int layer = 0; layer < 3; ++layer) {
    rows.push_back(json{{"type", layer == 2 ? "wall" : "segment"},
                        {"metaData", {{"segmentId", std::to_string(layer + 1)}}},
                        {"compressedPixels", {0, 2 * layer, 1000, 0, 2 * layer + 1, 1000}}});
  }
  limits = {};
  limits.max_total_pixels = 5000;
  expect_refused_naming(map_of(1000, rows), limits,
                        "layers[2].compressedPixels: more than the 1000 pixels left of the 5000 all layers "
                        "together may cover");
  limits.max_total_pixels = 6000;
  ASSERT_THAT(ParseValetudoMap(map_of(1000, rows), "export.json", limits), IsOk());
  // The per-layer limit, when it is the lesser, is named as before.
  limits = {};
  limits.max_layer_pixels = 1500;
  expect_refused_naming(map_of(1000, rows), limits,
                        "layers[0].compressedPixels: more than the limit of 1500 pixels a layer may cover");
}

TEST(ValetudoMapTest, RefusesMalformedExportsNamingTheField) {
  const json valid =
      ReadJson(test_data::Sample() / "valetudo/dreame_1c_1096_virtualwall_and_forbidden_zone.json");
  ASSERT_THAT(ParseValetudoMap(valid.dump(), "valid"), IsOk());
  struct Case {
    const char* what;
    std::function<void(json&)> edit;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {"class", [](json& m) { m["__class"] = "SomethingElse"; }, "__class: not \"ValetudoMap\""},
      {"version", [](json& m) { m["metaData"]["version"] = 3; }, "metaData.version: 3 is not supported"},
      {"no metaData", [](json& m) { m.erase("metaData"); }, "metaData: missing"},
      {"pixelSize", [](json& m) { m["pixelSize"] = 0; }, "map.pixelSize: 0 is outside [1, 100]"},
      {"absurd size", [](json& m) { m["size"]["x"] = 10'000'000; }, "size.x: 10000000 is outside [1, 20000]"},
      {"size type", [](json& m) { m["size"]["y"] = "big"; }, "size.y: not an integer"},
      // Past int64's range: named as written, not wrapped to a negative number.
      {"size past int64", [](json& m) { m["size"]["x"] = std::numeric_limits<std::uint64_t>::max(); },
       "size.x: 18446744073709551615 is outside [1, 20000]"},
      {"run past int64",
       [](json& m) { m["layers"][0]["compressedPixels"][2] = std::numeric_limits<std::uint64_t>::max(); },
       "layers[0].compressedPixels[2]: run leaves the map (x"},
      {"layers", [](json& m) { m["layers"] = 5; }, "layers: missing or not an array"},
      {"layer type", [](json& m) { m["layers"][1]["type"] = "carpet"; },
       "layers[1].type: unknown layer type \"carpet\""},
      {"truncated runs",
       [](json& m) {
         m["layers"][0]["compressedPixels"].erase(m["layers"][0]["compressedPixels"].size() - 1);
       },
       "layers[0].compressedPixels: length 56 is not a multiple of 3"},
      {"run off the map", [](json& m) { m["layers"][0]["compressedPixels"][2] = 100000; },
       "layers[0].compressedPixels[2]: run leaves the map"},
      {"zero run", [](json& m) { m["layers"][0]["compressedPixels"][2] = 0; },
       "layers[0].compressedPixels[2]: run length 0 < 1"},
      {"negative pixel", [](json& m) { m["layers"][2]["compressedPixels"][1] = -4; },
       "layers[2].compressedPixels[1]: -4 is outside the map"},
      {"odd pixels",
       [](json& m) {
         m["layers"][0].erase("compressedPixels");
         m["layers"][0]["pixels"] = {1, 2, 3};
       },
       "layers[0].pixels: length 3 is not a multiple of 2"},
      {"no pixels", [](json& m) { m["layers"][0].erase("compressedPixels"); }, "layers[0]: no pixels"},
      {"no encoding",
       [](json& m) {
         m["layers"][1].erase("compressedPixels");
         m["layers"][1].erase("pixels");
       },
       "layers[1]: neither pixels nor compressedPixels"},
      {"both encodings",
       [](json& m) {
         m["layers"][0]["pixels"] = {1, 2};
       },
       "layers[0]: both pixels and compressedPixels"},
      {"entity class", [](json& m) { m["entities"][0]["__class"] = "BlobMapEntity"; },
       "entities[0].__class: unknown entity class \"BlobMapEntity\""},
      {"point entity",
       [](json& m) {
         m["entities"][0]["points"] = {1, 2, 3, 4};
       },
       "entities[0].points: a point entity has one point"},
      {"odd points", [](json& m) { m["entities"][2]["points"].erase(0); },
       "entities[2].points: length 7 is not a multiple of 2"},
      {"angle", [](json& m) { m["entities"][1]["metaData"]["angle"] = "north"; },
       "entities[1].metaData.angle: not a number"},
      {"no layers", [](json& m) { m["layers"] = json::array(); }, "layers: no layer covers any pixel"},
  };
  for (const Case& test_case : cases) {
    SCOPED_TRACE(test_case.what);
    json broken = valid;
    test_case.edit(broken);
    const auto result = ParseValetudoMap(broken.dump(), "broken.json");
    ASSERT_THAT(result, StatusIs(slamcore::StatusCode::kInvalidArgument));
    EXPECT_NE(result.status().message().find(test_case.expected), std::string::npos)
        << result.status().message();
    EXPECT_EQ(result.status().message().rfind("broken.json: ", 0), 0u) << result.status().message();
  }
  for (const std::string& text : {std::string("{\"__class\": \"ValetudoMap\", "), std::string("[1, 2]"),
                                  std::string(""), std::string("\x78\x9c garbage")}) {
    const auto result = ParseValetudoMap(text, "text");
    ASSERT_FALSE(result.ok()) << text;
    EXPECT_THAT(result, StatusIs(slamcore::StatusCode::kInvalidArgument));
  }
  ValetudoLimits tight;
  tight.max_layers = 2;
  const auto many = ParseValetudoMap(valid.dump(), "many", tight);
  ASSERT_FALSE(many.ok());
  EXPECT_NE(many.status().message().find("layers: 5 layers, more than the limit 2"), std::string::npos);
  tight = {};
  tight.max_input_bytes = 100;
  EXPECT_NE(ParseValetudoMap(valid.dump(), "big", tight).status().message().find("more than the limit 100"),
            std::string::npos);
}

/// Hand-back: every export in data/valetudo, written back as ValetudoMap JSON, imports into the very same
/// grid (cells, size, origin) with the same dock and robot; a map_server-style grid at negative coordinates
/// is shifted onto pixels ≥ 0; what cannot be written is refused naming the field.
TEST(ValetudoWrite, RoundTripsEveryExportCellForCell) {
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(test_data::Sample() / "valetudo")) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().filename().string());
    ++files;
    const auto original = ReadValetudoMap(entry.path().string());
    ASSERT_THAT(original, IsOk());
    const auto written = WriteValetudoMap(original->grid, MetadataOf(*original));
    ASSERT_THAT(written, IsOk());
    const auto back = ParseValetudoMap(*written, "hand-back.json");
    ASSERT_THAT(back, IsOk());
    EXPECT_EQ(back->version, 2);
    EXPECT_EQ(back->pixel_size_cm, original->pixel_size_cm);
    EXPECT_EQ(back->grid.width, original->grid.width);
    EXPECT_EQ(back->grid.height, original->grid.height);
    EXPECT_DOUBLE_EQ(back->grid.origin_x, original->grid.origin_x);
    EXPECT_DOUBLE_EQ(back->grid.origin_y, original->grid.origin_y);
    EXPECT_TRUE(back->grid.cells == original->grid.cells);
    EXPECT_EQ(back->AreaOf("floor") + back->AreaOf("segment") + back->AreaOf("wall"),
              *back->declared_total_area_cm2);
    ASSERT_EQ(back->dock.has_value(), original->dock.has_value());
    if (original->dock) {
      EXPECT_NEAR(back->dock->pose.x(), original->dock->pose.x(), 0.005);
      EXPECT_NEAR(back->dock->pose.y(), original->dock->pose.y(), 0.005);
      EXPECT_NEAR(back->dock->pose.theta(), original->dock->pose.theta(), 0.01);
    }
    ASSERT_EQ(back->robot.has_value(), original->robot.has_value());
  }
  EXPECT_EQ(files, 5);
}

TEST(ValetudoWrite, ShiftsNegativeOriginsAndRefusesWhatItCannotWrite) {
  auto grid = slamcore::OccupancyGrid::Create(30, 20, 0.05, -10.0, -3.0);
  ASSERT_THAT(grid, IsOk());
  grid->at(0, 0) = 100;
  grid->at(5, 7) = 0;
  grid->at(29, 19) = 0;
  fleet::v1::MapMetadata dock;
  fleet::v1::MapPoint* charger = dock.add_points();
  charger->set_type("charger_location");
  charger->set_x(-9.5);
  charger->set_y(-2.5);
  charger->set_theta(0.5);
  const auto written = WriteValetudoMap(*grid, dock);
  ASSERT_THAT(written, IsOk());
  const auto back = ParseValetudoMap(*written, "shifted.json");
  ASSERT_THAT(back, IsOk());
  EXPECT_EQ(back->grid.CountCells(slamcore::CellState::kOccupied), 1);
  EXPECT_EQ(back->grid.CountCells(slamcore::CellState::kFree), 2);
  // Shifted by 10 m in x (pixels ≥ 0); the dock moved with the grid: 0.5 m right of the grid's left edge.
  ASSERT_TRUE(back->dock);
  EXPECT_NEAR(back->dock->pose.x() - back->grid.origin_x, 0.5 + 10 * 0.05, 0.01);  // import margin: 10 cells
  EXPECT_NEAR(back->dock->pose.theta(), 0.5, 0.01);

  slamcore::OccupancyGrid odd = *grid;
  odd.resolution = 0.025;
  auto refused = WriteValetudoMap(odd, {});
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("grid.resolution"), std::string::npos)
      << refused.status().ToString();
  auto blank = slamcore::OccupancyGrid::Create(4, 4, 0.05);
  ASSERT_THAT(blank, IsOk());
  refused = WriteValetudoMap(*blank, {});
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("no free or occupied cell"), std::string::npos);
  EXPECT_FALSE(WriteValetudoMap(slamcore::OccupancyGrid{}, {}).ok());
}

}  // namespace
}  // namespace analyzer
