// Deterministic serialisation of wire messages: equal messages give equal bytes everywhere (map fields in key
// order), so that snapshots are content-addressed by these bytes, by robots and by the server alike.
//
// Thread safety: a free function without shared state.
#pragma once

#include <google/protobuf/message.h>

#include <string>

namespace fleet {

/// The message's bytes with deterministic serialisation; empty for a message over protobuf's 2 GiB limit
/// (protobuf cannot encode one; every input the service takes is bounded far below it).
std::string SerializeDeterministic(const google::protobuf::Message& message);

}  // namespace fleet
