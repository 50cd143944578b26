// gRPC's status codes for the project: their names, and the one mapping between the project's status codes
// (slamcore/status.h) and gRPC's. fleetd answers with it (server/src/service_context.cc) and clients read
// answers back with it (sim/src/service_client.cc).
//
// Thread safety: free functions without shared state.
#pragma once

#include <grpcpp/support/status_code_enum.h>

#include "slamcore/status.h"

namespace fleet {

/// "UNAVAILABLE" for grpc::StatusCode 14, … (the names gRPC's documentation uses); "UNKNOWN" for a number
/// that is no code.
const char* GrpcCodeName(int code);

/// Each project code to gRPC's code of the same name.
grpc::StatusCode ToGrpcCode(slamcore::StatusCode code);

/// gRPC's code to the project's code of the same name, by the same table. The codes the project has no name
/// for go to the nearest meaning: DEADLINE_EXCEEDED, RESOURCE_EXHAUSTED and CANCELLED to kUnavailable (busy,
/// slow or going away: later may work), OUT_OF_RANGE to kInvalidArgument, PERMISSION_DENIED and
/// UNAUTHENTICATED to kFailedPrecondition (the caller needs other credentials first), UNKNOWN and
/// UNIMPLEMENTED to kInternal.
slamcore::StatusCode FromGrpcCode(grpc::StatusCode code);

}  // namespace fleet
