// Translation between the wire contract (proto/fleet/v1/telemetry.proto) and slamcore's types, at the
// boundary, in both directions. Uploaded data is untrusted: FromProto validates everything slamcore
// would refuse later (missing fields, wrong matrix sizes, NaN/inf, unknown format versions) and names the
// offending field, e.g. "events[12].odometry.covariance: expected 9 values, found 4".
//
// Thread safety: free functions without shared state.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "fleet/v1/telemetry.pb.h"
#include "slamcore/events.h"
#include "slamcore/mapper.h"

namespace analyzer {

inline constexpr unsigned kTelemetryFormatVersion = 1;

// Bounds on uploaded data (docs/formats/service.md, "Bounds"): what a robot can send is what the server can
// afford to replay and render.
inline constexpr std::size_t kMaxIdLength = 128;            // robot, run, parameter-set ids; firmware, model
inline constexpr double kEarliestRunSeconds = 946684800.0;  // 2000-01-01T00:00:00Z
inline constexpr double kLatestRunSeconds = 4102444800.0;   // 2100-01-01T00:00:00Z
inline constexpr double kMaxTimeSeconds =
    kLatestRunSeconds;                                // event and node times: run-relative or absolute
inline constexpr double kMinPatchResolution = 0.005;  // m/cell
inline constexpr double kMaxPatchResolution = 1.0;    // m/cell
inline constexpr int kMaxPatchSide = 2048;            // cells
inline constexpr double kMaxPatchExtent = 100.0;      // m on a side: a local patch, not a city
inline constexpr int kMaxSnapshotNodes = 500000;      // also views and local maps
inline constexpr int kMaxSnapshotEdges = 2000000;
inline constexpr std::int64_t kMaxSnapshotCells = 256LL << 20;  // all local maps of one snapshot

/// Ids (robot, run, parameter set): 1..128 characters of [A-Za-z0-9._:-], naming `field` when not.
slamcore::Status ValidateId(const std::string& value, const std::string& field);
/// Free text stored and shown (firmware, robot model): at most 128 characters, no control characters.
slamcore::Status ValidateText(const std::string& value, const std::string& field);
/// The path of the first (sub)message carrying fields this program does not know (e.g. bytes appended after
/// a snapshot), or nullopt. Uploads refuse them: stored runs hold only what was understood.
std::optional<std::string> FindUnknownField(const google::protobuf::Message& message,
                                            const std::string& field);
/// 64 lowercase hex characters.
bool IsSnapshotId(const std::string& value);

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
