// Snapshots cut into message-sized parts: merged in order they are the snapshot again, byte for byte in the
// deterministic serialisation that names a snapshot (so its id does not change), and each part keeps to the bound.
#include "fleet/snapshot_parts.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "fleet/serialization.h"

namespace {

TEST(SnapshotPartsTest, PartsMergedInOrderAreTheSnapshotAndEachStaysUnderTheBound) {
  fleet::v1::MapSnapshot snapshot;
  snapshot.set_format_version(1);
  snapshot.mutable_imported()->set_format("valetudo");
  for (int k = 0; k < 200; ++k) {
    fleet::v1::Node& node = *snapshot.add_nodes();
    node.set_id(k);
    node.set_time(k);
    fleet::v1::Edge& edge = *snapshot.add_edges();
    edge.set_from(k);
    edge.set_to(k + 1);
    for (int i = 0; i < 9; ++i) edge.add_information(i % 4 == 0 ? 100.0 : 0.0);
    snapshot.add_views()->set_node(k);
    fleet::v1::NodeLocalMap& patch = *snapshot.add_local_maps();
    patch.set_node(k);
    patch.mutable_local_map()->set_width(20);
    patch.mutable_local_map()->set_height(20);
    patch.mutable_local_map()->set_cells(std::string(400, static_cast<char>(k % 3)));
  }
  // One patch larger than a part travels alone.
  snapshot.mutable_local_maps(7)->mutable_local_map()->set_cells(std::string(9000, 1));
  constexpr std::size_t kPartBytes = 4096;
  const std::vector<fleet::v1::MapSnapshot> parts = fleet::SnapshotParts(snapshot, kPartBytes);
  ASSERT_GT(parts.size(), static_cast<std::size_t>(snapshot.ByteSizeLong() / kPartBytes));
  fleet::v1::MapSnapshot merged;
  int oversized = 0;
  for (const fleet::v1::MapSnapshot& part : parts) {
    if (part.ByteSizeLong() > kPartBytes) {
      ++oversized;
      EXPECT_EQ(part.local_maps_size(), 1) << "only the oversized patch, alone";
    }
    merged.MergeFrom(part);
  }
  EXPECT_EQ(oversized, 1);
  EXPECT_EQ(fleet::SerializeDeterministic(merged), fleet::SerializeDeterministic(snapshot));
  EXPECT_EQ(parts.front().imported().format(), "valetudo");
  // A small snapshot is one part, itself.
  fleet::v1::MapSnapshot small;
  small.add_nodes()->set_id(1);
  ASSERT_EQ(fleet::SnapshotParts(small, kPartBytes).size(), 1u);
  EXPECT_EQ(fleet::SerializeDeterministic(fleet::SnapshotParts(small, kPartBytes).front()),
            fleet::SerializeDeterministic(small));
}

}  // namespace
