// Fetching a robot's map as a robot does: Maps.StreamMap's messages merged into GetMap's answer. A lifelong
// map outgrows one gRPC message; the stream has no such limit, so the client sets its own.
//
// Thread safety: a free function; the stub is gRPC's (thread-safe), the context is the caller's, one per call.
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstddef>
#include <cstdint>

#include "fleet/v1/service.grpc.pb.h"

namespace fleet_client {

/// Maps.StreamMap(`request`), its messages merged in order into `answer` (GetMap's answer, field for field).
/// RESOURCE_EXHAUSTED, the stream cancelled and `answer` cleared, once the messages pass `max_bytes` together;
/// on any other failure, the server's status and `answer` cleared.
grpc::Status ReceiveMap(fleet::v1::Maps::StubInterface& maps, grpc::ClientContext& context,
                        const fleet::v1::GetMapRequest& request, std::size_t max_bytes,
                        fleet::v1::GetMapResponse* answer);

/// What a robot accepts by default: a stream's size, as fleetd accepts for one run (max_run_bytes).
inline constexpr std::size_t kDefaultMaxMapBytes = std::size_t{512} << 20;

}  // namespace fleet_client
