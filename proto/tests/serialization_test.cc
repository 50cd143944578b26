// SerializeDeterministic names every stored snapshot (its SHA-256 is the snapshot's id): its bytes must be
// protobuf's deterministic encoding exactly, however the function writes them.
#include "fleet/serialization.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <gtest/gtest.h>

#include <string>

#include "fleet/v1/telemetry.pb.h"

namespace {

/// The encoding written through a growing string: what protobuf itself produces with the flag set.
std::string ReferenceEncoding(const google::protobuf::Message& message) {
  std::string bytes;
  google::protobuf::io::StringOutputStream stream(&bytes);
  google::protobuf::io::CodedOutputStream coded(&stream);
  coded.SetSerializationDeterministic(true);
  message.SerializeToCodedStream(&coded);
  coded.Trim();
  return bytes;
}

TEST(SerializationTest, TheBytesAreProtobufsDeterministicEncoding) {
  fleet::v1::RunFile run;
  run.mutable_header()->set_robot_id("robot-7");
  run.mutable_header()->set_run_id("run-1");
  for (int k = 0; k < 300; ++k) {
    fleet::v1::Node& node = *run.mutable_child_snapshot()->add_nodes();
    node.set_id(k);
    node.set_time(0.1 * k);
    fleet::v1::NodeLocalMap& patch = *run.mutable_child_snapshot()->add_local_maps();
    patch.set_node(k);
    patch.mutable_local_map()->set_width(40);
    patch.mutable_local_map()->set_height(40);
    patch.mutable_local_map()->set_cells(std::string(1600, static_cast<char>(k % 5)));
  }
  run.add_events()->set_time(1.5);
  const std::string bytes = fleet::SerializeDeterministic(run);
  EXPECT_EQ(bytes.size(), run.ByteSizeLong());
  EXPECT_EQ(bytes, ReferenceEncoding(run));
  fleet::v1::RunFile parsed;
  ASSERT_TRUE(parsed.ParseFromString(bytes));
  EXPECT_EQ(fleet::SerializeDeterministic(parsed), bytes);
  // An empty message is no bytes.
  EXPECT_EQ(fleet::SerializeDeterministic(fleet::v1::MapSnapshot()), "");
}

// A small message: its bytes fit in the stream's own buffer, and in the string without an allocation.
TEST(SerializationTest, DeterministicBytesParseBackToTheSameMessage) {
  fleet::v1::MapSnapshot snapshot;
  for (int k = 0; k < 3; ++k) {
    fleet::v1::Node* node = snapshot.add_nodes();
    node->set_id(k);
  }
  const std::string bytes = fleet::SerializeDeterministic(snapshot);
  EXPECT_EQ(bytes, fleet::SerializeDeterministic(snapshot));
  EXPECT_EQ(bytes, ReferenceEncoding(snapshot));
  fleet::v1::MapSnapshot back;
  ASSERT_TRUE(back.ParseFromString(bytes));
  EXPECT_EQ(back.nodes_size(), 3);
  EXPECT_EQ(fleet::SerializeDeterministic(back), bytes);
}

}  // namespace
