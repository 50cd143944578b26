// How a client reaches fleetd: a gRPC channel of its own connection, plaintext or TLS. (The names of gRPC's
// status codes for messages, "UNAVAILABLE: …", are fleet::GrpcCodeName in fleet/status_codes.h.)
//
// Thread safety: a free function without shared state; a channel is thread-safe.
#pragma once

#include <memory>
#include <string>

namespace grpc {
class Channel;
}  // namespace grpc

namespace fleet_client {

/// A channel to fleetd: plaintext, or TLS trusting the CA in `tls_ca` (a PEM file) when it is not empty.
/// Messages up to `max_message_bytes` both ways.
std::shared_ptr<grpc::Channel> CreateFleetChannel(const std::string& server, const std::string& tls_ca,
                                                  int max_message_bytes);

}  // namespace fleet_client
