// The one mapping of the project's status codes to gRPC's and to HTTP's: every code, so a code added to
// slamcore/status.h cannot fall through to a default unnoticed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

#include "http_helpers.h"
#include "service_context.h"
#include "slamcore/status.h"
#include "status_matchers.h"

namespace server {
namespace {

using slamcore::StatusCode;

struct Mapping {
  StatusCode code;
  grpc::StatusCode grpc_code;
  int http_status;
};

const std::vector<Mapping> kMappings = {
    {StatusCode::kInvalidArgument, grpc::StatusCode::INVALID_ARGUMENT, 400},
    {StatusCode::kNotFound, grpc::StatusCode::NOT_FOUND, 404},
    {StatusCode::kAlreadyExists, grpc::StatusCode::ALREADY_EXISTS, 409},
    {StatusCode::kFailedPrecondition, grpc::StatusCode::FAILED_PRECONDITION, 409},
    {StatusCode::kAborted, grpc::StatusCode::ABORTED, 409},
    {StatusCode::kDataLoss, grpc::StatusCode::DATA_LOSS, 500},
    {StatusCode::kUnavailable, grpc::StatusCode::UNAVAILABLE, 503},
    {StatusCode::kInternal, grpc::StatusCode::INTERNAL, 500},
};

TEST(StatusMappingTest, EveryCodeToTheSameNamedGrpcCode) {
  EXPECT_THAT(ToGrpc(slamcore::Status::Ok()), IsOk());
  for (const Mapping& mapping : kMappings) {
    const grpc::Status mapped = ToGrpc(slamcore::Status(mapping.code, "run r1 of robot a"));
    EXPECT_EQ(mapped.error_code(), mapping.grpc_code) << slamcore::StatusCodeName(mapping.code);
    EXPECT_EQ(mapped.error_message(), "run r1 of robot a");
  }
}

TEST(StatusMappingTest, EveryCodeToItsHttpStatusNamingTheCode) {
  for (const Mapping& mapping : kMappings) {
    const HttpResponse response = http::Error(slamcore::Status(mapping.code, "map moved on"));
    EXPECT_EQ(response.status, mapping.http_status) << slamcore::StatusCodeName(mapping.code);
    const nlohmann::json body = nlohmann::json::parse(response.body);
    EXPECT_EQ(body["error"], "map moved on");
    EXPECT_EQ(body["code"], slamcore::StatusCodeName(mapping.code));
  }
}

}  // namespace
}  // namespace server
