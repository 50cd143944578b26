// The status-code table both ways and gRPC's code names.
#include <gtest/gtest.h>

#include <string>

#include "fleet/status_codes.h"
#include "slamcore/status.h"

namespace fleet {
namespace {

using slamcore::StatusCode;

TEST(StatusCodesTest, EveryProjectCodeToTheGrpcCodeOfTheSameNameAndBack) {
  for (int k = 0; k <= static_cast<int>(StatusCode::kInternal); ++k) {
    const auto code = static_cast<StatusCode>(k);
    EXPECT_STREQ(GrpcCodeName(ToGrpcCode(code)), slamcore::StatusCodeName(code));
    EXPECT_EQ(FromGrpcCode(ToGrpcCode(code)), code) << slamcore::StatusCodeName(code);
  }
}

TEST(StatusCodesTest, GrpcCodesWithoutAProjectNameToTheNearestMeaning) {
  const std::pair<grpc::StatusCode, StatusCode> expected[] = {
      {grpc::StatusCode::CANCELLED, StatusCode::kUnavailable},
      {grpc::StatusCode::UNKNOWN, StatusCode::kInternal},
      {grpc::StatusCode::DEADLINE_EXCEEDED, StatusCode::kUnavailable},
      {grpc::StatusCode::PERMISSION_DENIED, StatusCode::kFailedPrecondition},
      {grpc::StatusCode::RESOURCE_EXHAUSTED, StatusCode::kUnavailable},
      {grpc::StatusCode::OUT_OF_RANGE, StatusCode::kInvalidArgument},
      {grpc::StatusCode::UNIMPLEMENTED, StatusCode::kInternal},
      {grpc::StatusCode::UNAUTHENTICATED, StatusCode::kFailedPrecondition},
  };
  for (const auto& [grpc_code, code] : expected) {
    EXPECT_EQ(FromGrpcCode(grpc_code), code) << GrpcCodeName(grpc_code);
  }
}

TEST(StatusCodesTest, EveryGrpcCodeHasItsName) {
  EXPECT_STREQ(GrpcCodeName(grpc::StatusCode::OK), "OK");
  EXPECT_STREQ(GrpcCodeName(grpc::StatusCode::UNAVAILABLE), "UNAVAILABLE");
  EXPECT_STREQ(GrpcCodeName(grpc::StatusCode::UNAUTHENTICATED), "UNAUTHENTICATED");
  EXPECT_STREQ(GrpcCodeName(-1), "UNKNOWN");
  EXPECT_STREQ(GrpcCodeName(17), "UNKNOWN");
}

}  // namespace
}  // namespace fleet
