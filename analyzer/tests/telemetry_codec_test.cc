#include "analyzer/telemetry_codec.h"

#include <gtest/gtest.h>

#include <cmath>

#include "status_matchers.h"

namespace analyzer {
namespace {

using slamcore::Matrix3;
using slamcore::SE2;

std::vector<slamcore::Event> SampleEvents() {
  slamcore::LocalMapEvent patch;
  patch.time = 3.0;
  patch.resolution = 0.05;
  patch.width = 3;
  patch.height = 2;
  patch.node_T_origin = SE2(-0.1, -0.05, 0.0);
  patch.cells = {-1, 0, 100, 0, 0, -1};
  Matrix3 covariance = Matrix3::Identity() * 0.01;
  covariance(0, 1) = covariance(1, 0) = 0.002;
  return {
      slamcore::OdometryEvent{.time = 1.0, .increment = SE2(0.2, 0.01, 0.05), .covariance = covariance},
      slamcore::ViewCreatedEvent{.time = 1.5, .view = 7},
      slamcore::ViewObservedEvent{
          .time = 2.0, .view = 7, .robot_T_view = SE2(1.0, -0.5, 3.0), .covariance = covariance * 2.0},
      patch,
      slamcore::KidnapEvent{.time = 4.0, .cause = slamcore::KidnapEvent::Cause::kReboot},
      slamcore::GroundTruthEvent{.time = 5.0, .world_T_robot = SE2(4.0, 5.0, -1.0)},
  };
}

TEST(TelemetryCodecTest, EventsRoundTripExactly) {
  for (const slamcore::Event& event : SampleEvents()) {
    const fleet::v1::Event proto = ToProto(event);
    const auto back = FromProto(proto, "event");
    ASSERT_THAT(back, IsOk());
    // Serialising the decoded event again gives the same bytes: nothing was lost or changed.
    EXPECT_EQ(ToProto(*back).SerializeAsString(), proto.SerializeAsString());
    EXPECT_EQ(back->index(), event.index());
  }
}

TEST(TelemetryCodecTest, MapSnapshotRoundTripsAndSerialisesDeterministically) {
  slamcore::Map map;
  for (int k = 0; k < 3; ++k) {
    ASSERT_THAT(map.graph.AddNode({.id = k,
                                   .pose = SE2(k, 0.5 * k, 0.1 * k),
                                   .time = 1.0 * k,
                                   .odometer = 1.0 * k,
                                   .fixed = false}),
                IsOk());
  }
  ASSERT_THAT(map.graph.AddView({.id = 10, .node = 0, .ambiguous = true}), IsOk());
  slamcore::Edge motion;
  motion.from = 0;
  motion.to = 1;
  motion.measurement = SE2(1.0, 0.5, 0.1);
  ASSERT_THAT(map.graph.AddEdge(motion), IsOk());
  slamcore::Edge observation;
  observation.from = 2;
  observation.to = 0;
  observation.kind = slamcore::EdgeKind::kObservation;
  observation.view = 10;
  ASSERT_THAT(map.graph.AddEdge(observation), IsOk());
  map.local_maps[1] = std::get<slamcore::LocalMapEvent>(SampleEvents()[3]);

  const fleet::v1::MapSnapshot proto = ToProto(map);
  const auto back = FromProto(proto, "snapshot");
  ASSERT_THAT(back, IsOk());
  EXPECT_EQ(back->graph.num_nodes(), 3u);
  EXPECT_EQ(back->graph.NumComponents(), 1u);
  EXPECT_TRUE(back->graph.view(10).ambiguous);
  EXPECT_EQ(back->graph.edges()[1].view, std::optional<slamcore::ViewId>(10));
  EXPECT_EQ(back->local_maps.at(1).cells, map.local_maps.at(1).cells);
  EXPECT_EQ(ToProto(*back).SerializeAsString(), proto.SerializeAsString());
}

TEST(TelemetryCodecTest, EmptySnapshotIsTheEmptyMap) {
  const auto map = FromProto(fleet::v1::MapSnapshot(), "parent_snapshot");
  ASSERT_THAT(map, IsOk());
  EXPECT_EQ(map->graph.num_nodes(), 0u);
}

void ExpectRefused(const fleet::v1::Event& event, const std::string& fragment) {
  const auto result = FromProto(event, "events[4]");
  ASSERT_FALSE(result.ok());
  EXPECT_NE(result.status().message().find(fragment), std::string::npos) << result.status().message();
}

TEST(TelemetryCodecTest, BadEventsAreRefusedNamingTheField) {
  fleet::v1::Event event = ToProto(SampleEvents()[0]);
  event.mutable_odometry()->mutable_covariance()->RemoveLast();
  ExpectRefused(event, "events[4].odometry.covariance: expected 9 values, found 8");

  event = ToProto(SampleEvents()[0]);
  event.mutable_odometry()->mutable_increment()->set_x(std::nan(""));
  ExpectRefused(event, "events[4].odometry.increment: not finite");

  event = ToProto(SampleEvents()[2]);
  event.mutable_view_observed()->set_covariance(8, -1.0);
  ExpectRefused(event, "events[4].view_observed.covariance is not positive definite");

  event = ToProto(SampleEvents()[2]);
  event.mutable_view_observed()->clear_robot_t_view();
  ExpectRefused(event, "events[4].view_observed.robot_t_view: missing");

  event = ToProto(SampleEvents()[3]);
  event.mutable_local_map()->set_cells("ab");
  ExpectRefused(event, "events[4].local_map.cells: expected 6 bytes, found 2");

  event = ToProto(SampleEvents()[3]);
  event.mutable_local_map()->set_width(100000);
  event.mutable_local_map()->set_height(100000);
  ExpectRefused(event, "larger than 2048x2048");

  // The memory attack of issue 16: one cell at 400 m/cell covers a city in the renderer's grid.
  event = ToProto(SampleEvents()[3]);
  event.mutable_local_map()->set_resolution(400.0);
  ExpectRefused(event, "events[4].local_map.resolution: 400 m/cell is outside [0.005, 1]");
  event.mutable_local_map()->set_resolution(0.001);
  ExpectRefused(event, "events[4].local_map.resolution: 0.001 m/cell is outside [0.005, 1]");
  event.mutable_local_map()->set_resolution(0.9);
  event.mutable_local_map()->set_width(200);
  event.mutable_local_map()->set_height(1);
  event.mutable_local_map()->set_cells(std::string(200, '\0'));
  ExpectRefused(event, "events[4].local_map: footprint 180 x 0.9 m is larger than 100 m on a side");

  event = ToProto(SampleEvents()[0]);
  event.set_time(-1.0);
  ExpectRefused(event, "events[4].time: -1 s is outside [0, 4.10244e+09]");
  event.set_time(1e300);
  ExpectRefused(event, "events[4].time: 1e+300 s is outside");

  ExpectRefused(fleet::v1::Event(), "events[4]: no event kind set");
}

TEST(TelemetryCodecTest, SnapshotsOfUnknownVersionOrBrokenReferencesAreRefused) {
  fleet::v1::MapSnapshot snapshot;
  snapshot.set_format_version(2);
  snapshot.add_nodes()->set_id(1);
  auto result = FromProto(snapshot, "child_snapshot");
  ASSERT_FALSE(result.ok());
  EXPECT_NE(result.status().message().find("child_snapshot.format_version: 2 is not supported"),
            std::string::npos);

  snapshot.set_format_version(1);
  snapshot.mutable_nodes(0)->mutable_pose();
  auto* view = snapshot.add_views();
  view->set_id(5);
  view->set_node(99);
  result = FromProto(snapshot, "child_snapshot");
  ASSERT_FALSE(result.ok());
  EXPECT_NE(result.status().message().find("child_snapshot.views[0]: view 5: node 99 does not exist"),
            std::string::npos)
      << result.status().message();
}

TEST(TelemetryCodecTest, HeaderValidation) {
  fleet::v1::RunHeader header;
  header.set_format_version(1);
  header.set_robot_id("robot-1");
  header.set_run_id("run-1");
  header.set_started_at(1.7e9);
  header.set_ended_at(1.7e9 + 100.0);
  EXPECT_THAT(Validate(header), IsOk());
  // Ids: 1..128 of [A-Za-z0-9._:-] for every role; no control characters anywhere (issue 16: a robot id
  // "x\r\nSet-Cookie: a=b" ended up in a response header).
  header.set_robot_id("x\r\nSet-Cookie: a=b");
  EXPECT_EQ(Validate(header).message(), "header.robot_id: only letters, digits and . _ : - are allowed");
  header.set_robot_id(std::string(129, 'r'));
  EXPECT_EQ(Validate(header).message(), "header.robot_id: longer than 128 characters");
  header.set_robot_id("robot-1");
  header.set_run_id("run 1");
  EXPECT_EQ(Validate(header).message(), "header.run_id: only letters, digits and . _ : - are allowed");
  header.set_run_id("run-1");
  header.set_firmware("1.2\n");
  EXPECT_EQ(Validate(header).message(), "header.firmware: control characters are not allowed");
  header.set_firmware("1.2");
  header.set_home_id(std::string(129, 'h'));
  EXPECT_EQ(Validate(header).message(), "header.home_id: longer than 128 characters");
  header.set_home_id("home-1");
  header.set_parent_snapshot_id("../../etc");
  EXPECT_EQ(Validate(header).message(),
            "header.parent_snapshot_id: expected 64 lowercase hex characters (SHA-256)");
  header.set_parent_snapshot_id("");
  // Times: 2000-01-01..2100-01-01 (issue 16: started_at = -9.2e15 made day keys like "-291534425-09-").
  header.set_started_at(-9.2e15);
  EXPECT_EQ(Validate(header).message(),
            "header.started_at: -9.2e+15 is outside 2000-01-01..2100-01-01 (seconds since 1970, UTC)");
  header.set_started_at(4.2e9);
  EXPECT_NE(Validate(header).message().find("header.started_at: 4.2e+09 is outside"), std::string::npos);
  header.set_started_at(1.7e9);
  header.set_run_id("");
  EXPECT_EQ(Validate(header).message(), "header.run_id: missing");
  header.set_run_id("run-1");
  header.set_ended_at(1.7e9 - 50.0);
  EXPECT_EQ(Validate(header).message(), "header.ended_at: before started_at");
  header.set_format_version(9);
  EXPECT_NE(Validate(header).message().find("header.format_version: 9 is not supported"), std::string::npos);
}

}  // namespace
}  // namespace analyzer
