// Upload streams and bytes in flight (server/src/ingest_admission.h): refusals name the limit, tickets
// give back what they held, and one principal's uploads do not use up another's.
#include <gtest/gtest.h>

#include <memory>

#include "ingest_admission.h"
#include "status_matchers.h"

namespace server {
namespace {

TEST(IngestAdmissionTest, StreamsAndBytesAreBoundedPerPrincipalAndInAll) {
  IngestAdmission admission({/*max_streams=*/3, /*max_streams_per_principal=*/2, /*max_bytes=*/1000,
                             /*max_bytes_per_principal=*/600});
  auto a1 = std::make_unique<IngestAdmission::Ticket>();
  IngestAdmission::Ticket a2, a3, b1, c1;
  ASSERT_THAT(admission.Admit("robot:a", *a1), IsOk());
  ASSERT_THAT(admission.Admit("robot:a", a2), IsOk());
  grpc::Status third = admission.Admit("robot:a", a3);
  EXPECT_EQ(third.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(third.error_message().find("max_upload_streams_per_principal 2"), std::string::npos)
      << third.error_message();
  ASSERT_THAT(admission.Admit("robot:b", b1), IsOk());
  grpc::Status full = admission.Admit("robot:c", c1);
  EXPECT_NE(full.error_message().find("max_upload_streams 3"), std::string::npos) << full.error_message();

  EXPECT_THAT(a1->Reserve(500), IsOk());
  grpc::Status mine = a2.Reserve(200);
  EXPECT_EQ(mine.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(mine.error_message().find("max_upload_bytes_per_principal (600)"), std::string::npos);
  EXPECT_THAT(b1.Reserve(450), IsOk());
  grpc::Status all = a2.Reserve(60);
  EXPECT_NE(all.error_message().find("max_upload_bytes_in_flight (1000)"), std::string::npos)
      << all.error_message();
  EXPECT_EQ(admission.bytes(), 950);

  a1.reset();  // the call ended: its stream and bytes are free again
  EXPECT_EQ(admission.streams(), 2);
  EXPECT_EQ(admission.bytes(), 450);
  EXPECT_THAT(a2.Reserve(550), IsOk());
  EXPECT_THAT(admission.Admit("robot:c", c1), IsOk());
}

}  // namespace
}  // namespace server
