// Metadata of imported maps (analyzer/map_metadata.h): a real export's rooms, zones, walls and poses are read,
// absurd or malformed metadata is refused naming the field, rooms' names sit inside the room; and the order of
// a series of imports (analyzer/import_order.h): exports' own timestamps, dates and numbers in file names.
#include "analyzer/map_metadata.h"

#include <gtest/gtest.h>

#include "analyzer/import_order.h"
#include "test_data.h"
#include "status_matchers.h"

namespace analyzer {
namespace {

fleet::v1::MapMetadata ViomiMetadata() {
  const auto map = ReadValetudoMap(
      (test_data::Sample() / "valetudo/3irobotix_viomi_v6_41_virtual_restrictions_and_active_zones.json")
          .string());
  EXPECT_THAT(map, IsOk());
  return map.ok() ? MetadataOf(*map) : fleet::v1::MapMetadata();
}

TEST(MapMetadata, AnExportsRoomsZonesWallsAndPosesAreKept) {
  const fleet::v1::MapMetadata metadata = ViomiMetadata();
  EXPECT_EQ(metadata.format(), "valetudo");
  ASSERT_EQ(metadata.rooms_size(), 2);
  EXPECT_EQ(metadata.rooms(0).segment_id(), "10");
  EXPECT_EQ(metadata.rooms(0).name(), "room1");
  EXPECT_EQ(metadata.virtual_walls_size(), 2);
  EXPECT_EQ(metadata.zones_size(), 4);  // two no-go areas, two active zones
  EXPECT_EQ(metadata.paths_size(), 1);
  ASSERT_EQ(metadata.points_size(), 2);
  EXPECT_EQ(metadata.points(0).type(), "robot_position");
  EXPECT_EQ(metadata.points(1).type(), "charger_location");
  EXPECT_THAT(ValidateMetadata(metadata), IsOk());
  // The room's runs hold its pixels; its name goes at a point inside it.
  std::int64_t pixels = 0;
  for (int i = 2; i < metadata.rooms(0).runs_size(); i += 3) pixels += metadata.rooms(0).runs(i);
  EXPECT_EQ(pixels, metadata.rooms(0).pixel_count());
  const auto centre = RoomCentre(metadata.rooms(0), metadata.resolution());
  ASSERT_TRUE(centre);
  const auto& runs = metadata.rooms(0).runs();
  int min_y = runs[1], max_y = runs[1];
  for (int i = 1; i < runs.size(); i += 3) {
    min_y = std::min(min_y, runs[i]);
    max_y = std::max(max_y, runs[i]);
  }
  EXPECT_GT((*centre)[1], -(max_y + 1) * metadata.resolution());
  EXPECT_LT((*centre)[1], -(min_y - 1) * metadata.resolution());
}

TEST(MapMetadata, AbsurdOrMalformedMetadataIsRefusedNamingTheField) {
  const auto refused = [](const fleet::v1::MapMetadata& metadata, const std::string& field) {
    const slamcore::Status status = ValidateMetadata(metadata);
    EXPECT_EQ(status.code(), slamcore::StatusCode::kInvalidArgument) << field;
    EXPECT_NE(status.message().find(field), std::string::npos) << status.ToString();
  };
  fleet::v1::MapMetadata zones = ViomiMetadata();
  for (int i = 0; i < 1000; ++i) *zones.add_zones() = zones.zones(0);
  refused(zones, "metadata.zones: 1004 shapes, more than the limit 1000");
  fleet::v1::MapMetadata rooms = ViomiMetadata();
  for (int i = 0; i < 255; ++i) *rooms.add_rooms() = rooms.rooms(0);
  refused(rooms, "metadata.rooms: 257 rooms, more than the limit 256");
  fleet::v1::MapMetadata name = ViomiMetadata();
  name.mutable_rooms(1)->set_name(std::string(1 << 20, 'x'));
  refused(name, "metadata.rooms[1].name: 1048576 bytes, more than the limit 256");
  fleet::v1::MapMetadata control = ViomiMetadata();
  control.mutable_rooms(0)->set_name("kitchen\n<script>");
  refused(control, "metadata.rooms[0].name: holds a control character");
  fleet::v1::MapMetadata runs = ViomiMetadata();
  runs.mutable_rooms(0)->add_runs(7);
  refused(runs, "metadata.rooms[0].runs: length is not a multiple of 3");
  fleet::v1::MapMetadata empty_run = ViomiMetadata();
  empty_run.mutable_rooms(0)->set_runs(2, 0);
  refused(empty_run, "metadata.rooms[0].runs[0]");
  fleet::v1::MapMetadata claimed = ViomiMetadata();
  claimed.mutable_rooms(0)->set_pixel_count(1'000'000'000);
  refused(claimed, "metadata.rooms[0].pixel_count");
  fleet::v1::MapMetadata wall = ViomiMetadata();
  wall.mutable_virtual_walls(0)->mutable_xy()->Truncate(2);
  refused(wall, "metadata.virtual_walls[0].xy: 1 points, fewer than 2");
  fleet::v1::MapMetadata far = ViomiMetadata();
  far.mutable_zones(1)->set_xy(3, 1e12);
  refused(far, "metadata.zones[1].xy[3]: not a finite coordinate");
  fleet::v1::MapMetadata path = ViomiMetadata();
  path.mutable_paths(0)->mutable_xy()->Resize(200'002, 1.0);
  refused(path, "metadata.paths+virtual_walls+zones: ");
  fleet::v1::MapMetadata pose = ViomiMetadata();
  pose.mutable_points(1)->set_theta(std::nan(""));
  refused(pose, "metadata.points[1].theta: not finite");
  fleet::v1::MapMetadata format = ViomiMetadata();
  format.set_format("roomba");
  refused(format, "metadata.format");
  fleet::v1::MapMetadata resolution = ViomiMetadata();
  resolution.set_resolution(0.0);
  refused(resolution, "metadata.resolution");
  EXPECT_THAT(ValidateMetadata(fleet::v1::MapMetadata()), IsOk());
}

TEST(ImportOrder, DateTimesAreReadAsISO8601InUTCOrWithTheirOffset) {
  EXPECT_EQ(ParseIsoDateTime("1970-01-01T00:00:00Z"), 0);
  EXPECT_EQ(ParseIsoDateTime("2024-03-05T10:20:30.250Z"), 1709634030250);
  EXPECT_EQ(ParseIsoDateTime("2024-03-05T11:20:30+01:00"), 1709634030000);
  EXPECT_EQ(ParseIsoDateTime("2024-03-05"), 1709596800000);
  EXPECT_FALSE(ParseIsoDateTime("2024-02-30T00:00:00Z"));
  EXPECT_FALSE(ParseIsoDateTime("yesterday"));
  EXPECT_FALSE(ParseIsoDateTime("2024-03-05T10:20:30Z trailing"));
  EXPECT_EQ(DateTimeInName("map_2024-03-05T10-20-30.json"), 1709634030000);
  EXPECT_EQ(DateTimeInName("valetudo-20240305_102030.json"), 1709634030000);
  EXPECT_EQ(DateTimeInName("kitchen 2024-03-05.yaml"), 1709596800000);
  EXPECT_FALSE(DateTimeInName("map_3.yaml"));
  EXPECT_FALSE(DateTimeInName("scan_123456789012.yaml"));  // a long number is no date
  EXPECT_EQ(NumbersInName("map_3_v12.yaml"), (std::vector<std::int64_t>{3, 12}));
}

TEST(ImportOrder, TimeOrderPrefersTheExportsOwnTimestampsThenNamesElseKeepsTheGivenOrder) {
  // Own timestamps decide when every file has one, whatever the names say.
  ImportOrder order =
      OrderImports({{"b_2020-01-01.json", 300}, {"a_2030-01-01.json", 100}, {"c.json", 200}}, true);
  EXPECT_EQ(order.basis, "export timestamps");
  EXPECT_EQ(order.order, (std::vector<std::size_t>{1, 2, 0}));
  // Dates in every name.
  order = OrderImports({{"home_2024-05-01.json", std::nullopt}, {"home_2024-04-30T23-00.json", 5}}, true);
  EXPECT_EQ(order.basis, "dates in file names");
  EXPECT_EQ(order.order, (std::vector<std::size_t>{1, 0}));
  // Numbers compare as numbers (10 after 9), field by field.
  order = OrderImports({{"map_10.yaml", {}}, {"map_9.yaml", {}}, {"map_9b_2.yaml", {}}}, true);
  EXPECT_EQ(order.basis, "numbers in file names");
  EXPECT_EQ(order.order, (std::vector<std::size_t>{1, 2, 0}));
  // A file with no time at all: as given, saying which.
  order = OrderImports({{"map_2.yaml", {}}, {"kitchen.yaml", {}}, {"map_1.yaml", {}}}, true);
  EXPECT_EQ(order.basis, "given");
  EXPECT_NE(order.note.find("kitchen.yaml"), std::string::npos);
  EXPECT_EQ(order.order, (std::vector<std::size_t>{0, 1, 2}));
  // --order given.
  order = OrderImports({{"map_2.yaml", {}}, {"map_1.yaml", {}}}, false);
  EXPECT_EQ(order.basis, "given");
  EXPECT_EQ(order.order, (std::vector<std::size_t>{0, 1}));
}

TEST(ImportOrder, AValetudoExportsOwnTimestampIsReadAndAMalformedOneRefused) {
  const std::string head = R"({"__class":"ValetudoMap","metaData":{"version":2,)";
  const std::string tail =
      R"(},"size":{"x":10,"y":10},"pixelSize":5,"layers":[{"__class":"MapLayer","type":"floor","compressedPixels":[1,1,3]}],"entities":[]})";
  auto map = ParseValetudoMap(head + R"("timestamp":"2024-03-05T10:20:30Z")" + tail, "stamped.json");
  ASSERT_THAT(map, IsOk());
  EXPECT_EQ(map->timestamp_ms, 1709634030000);
  map = ParseValetudoMap(head + R"("timestamp":"last tuesday")" + tail, "bad.json");
  ASSERT_FALSE(map.ok());
  EXPECT_NE(map.status().message().find("metaData.timestamp"), std::string::npos) << map.status().ToString();
  map = ParseValetudoMap(head + R"("totalLayerArea":75)" + tail, "plain.json");
  ASSERT_THAT(map, IsOk());
  EXPECT_FALSE(map->timestamp_ms);
}

}  // namespace
}  // namespace analyzer
