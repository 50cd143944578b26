// A map snapshot cut into parts that each fit a gRPC message, and put back together. Robots upload their
// child map in parts (Ingest.UploadRun) and fetch their map in parts (Maps.StreamMap): a lifelong map grows
// with every run it keeps and outgrows one message long before it outgrows a stream.
//
// Thread safety: free functions on values.
#pragma once

#include <cstddef>
#include <vector>

#include "fleet/v1/telemetry.pb.h"

namespace fleet {

/// `snapshot` cut into parts, in order: each at most about `part_bytes` serialized (an item larger than that
/// travels alone), the first with its scalar fields. Merged in order (protobuf merge: repeated fields
/// concatenated) they are `snapshot` again, field for field. Its items are moved into the parts: pass it with
/// std::move when it is not needed afterwards, and a map is never held twice.
std::vector<v1::MapSnapshot> SnapshotParts(v1::MapSnapshot snapshot, std::size_t part_bytes);

}  // namespace fleet
