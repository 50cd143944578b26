// Translation between the wire contract (proto/fleet/v1/telemetry.proto) and slamcore's types, at the
// boundary, in both directions. Uploaded data is untrusted: FromProto validates everything slamcore
// would refuse later (missing fields, wrong matrix sizes, NaN/inf, unknown format versions) and names the
// offending field, e.g. "events[12].odometry.covariance: expected 9 values, found 4".
//
// Thread safety: free functions without shared state.
#pragma once

#include <string>
#include <vector>

#include "fleet/v1/telemetry.pb.h"
#include "slamcore/events.h"
#include "slamcore/mapper.h"

namespace analyzer {

inline constexpr unsigned kTelemetryFormatVersion = 1;

/// `field` prefixes error messages, e.g. "events[12]".
slamcore::Result<slamcore::Event> FromProto(const fleet::v1::Event& event, const std::string& field);
fleet::v1::Event ToProto(const slamcore::Event& event);

slamcore::Result<std::vector<slamcore::Event>> FromProto(
    const google::protobuf::RepeatedPtrField<fleet::v1::Event>& events, const std::string& field);

/// An empty snapshot (no nodes) is the empty map of a robot's first run.
slamcore::Result<slamcore::Map> FromProto(const fleet::v1::MapSnapshot& snapshot, const std::string& field);
fleet::v1::MapSnapshot ToProto(const slamcore::Map& map);

/// The message's bytes with deterministic serialisation (map fields in key order), so that equal messages give
/// equal bytes everywhere: snapshots are content-addressed by these bytes, by robots and by the server alike.
std::string SerializeDeterministic(const google::protobuf::Message& message);

/// Checks a run header: format version, ids present, times ordered.
slamcore::Status Validate(const fleet::v1::RunHeader& header);

}  // namespace analyzer
