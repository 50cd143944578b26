// The one Status and Result: its macros and the gMock matchers the tests use on it.
#include "slamcore/status.h"

#include <gmock/gmock.h>
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "status_matchers.h"

namespace slamcore {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

Result<int> Parse(const std::string& text) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) {
    return InvalidArgument("not a number: \"" + text + "\"");
  }
  return std::stoi(text);
}

Result<int> Sum(const std::string& a, const std::string& b, std::vector<std::string>* steps) {
  ASSIGN_OR_RETURN(auto first, Parse(a));
  steps->push_back("first " + std::to_string(first));
  ASSIGN_OR_RETURN(const auto second, Parse(b));
  steps->push_back("second " + std::to_string(second));
  return first + second;
}

Status AssignExisting(const std::string& text, int* out) {
  int value = -1;
  ASSIGN_OR_RETURN(value, Parse(text));
  *out = value;
  return Status::Ok();
}

Result<std::unique_ptr<int>> MakeBox(int value) {
  if (value < 0) return FailedPrecondition("negative");
  return std::make_unique<int>(value);
}

Result<int> Unbox(int value) {
  ASSIGN_OR_RETURN(std::unique_ptr<int> box, MakeBox(value));  // a move-only value
  return *box + 1;
}

Status Step(bool fail, const std::string& name, std::vector<std::string>* steps) {
  if (fail) return Aborted(name + " failed");
  steps->push_back(name);
  return Status::Ok();
}

// A body inside a checked call, as storage runs a transaction: both levels return through RETURN_IF_ERROR.
Status Transaction(const std::function<Status()>& body, std::vector<std::string>* steps) {
  steps->push_back("begin");
  RETURN_IF_ERROR(body());
  steps->push_back("commit");
  return Status::Ok();
}

Status Nested(bool fail_inner, std::vector<std::string>* steps) {
  RETURN_IF_ERROR(Transaction(
      [&]() -> Status {
        RETURN_IF_ERROR(Step(false, "a", steps));
        RETURN_IF_ERROR(Step(fail_inner, "b", steps));
        RETURN_IF_ERROR(Step(false, "c", steps));
        return Status::Ok();
      },
      steps));
  steps->push_back("after");
  return Status::Ok();
}

TEST(StatusTest, CodeNamesAreGrpcSpellings) {
  EXPECT_STREQ(StatusCodeName(StatusCode::kOk), "OK");
  EXPECT_STREQ(StatusCodeName(StatusCode::kInvalidArgument), "INVALID_ARGUMENT");
  EXPECT_STREQ(StatusCodeName(StatusCode::kNotFound), "NOT_FOUND");
  EXPECT_STREQ(StatusCodeName(StatusCode::kAlreadyExists), "ALREADY_EXISTS");
  EXPECT_STREQ(StatusCodeName(StatusCode::kFailedPrecondition), "FAILED_PRECONDITION");
  EXPECT_STREQ(StatusCodeName(StatusCode::kAborted), "ABORTED");
  EXPECT_STREQ(StatusCodeName(StatusCode::kDataLoss), "DATA_LOSS");
  EXPECT_STREQ(StatusCodeName(StatusCode::kUnavailable), "UNAVAILABLE");
  EXPECT_STREQ(StatusCodeName(StatusCode::kInternal), "INTERNAL");
  EXPECT_EQ(Unavailable("db busy").ToString(), "UNAVAILABLE: db busy");
  EXPECT_EQ(Status::Ok().ToString(), "OK");
}

TEST(StatusTest, AssignOrReturnDeclaresAndAssigns) {
  std::vector<std::string> steps;
  const Result<int> sum = Sum("40", "2", &steps);
  ASSERT_THAT(sum, IsOk());
  EXPECT_EQ(*sum, 42);
  EXPECT_EQ(steps, (std::vector<std::string>{"first 40", "second 2"}));

  int out = 0;
  ASSERT_THAT(AssignExisting("17", &out), IsOk());
  EXPECT_EQ(out, 17);

  const Result<int> unboxed = Unbox(6);
  ASSERT_THAT(unboxed, IsOk());
  EXPECT_EQ(*unboxed, 7);
}

TEST(StatusTest, AssignOrReturnReturnsTheErrorAndStops) {
  std::vector<std::string> steps;
  const Result<int> sum = Sum("40", "x", &steps);
  EXPECT_THAT(sum, StatusIs(StatusCode::kInvalidArgument, "not a number: \"x\""));
  EXPECT_EQ(steps, (std::vector<std::string>{"first 40"}));  // the second value was never used

  steps.clear();
  EXPECT_THAT(Sum("", "2", &steps), StatusIs(StatusCode::kInvalidArgument, "\"\""));
  EXPECT_TRUE(steps.empty());

  int out = 5;
  EXPECT_THAT(AssignExisting("seven", &out), StatusIs(StatusCode::kInvalidArgument, "seven"));
  EXPECT_EQ(out, 5);
  EXPECT_THAT(Unbox(-1), StatusIs(StatusCode::kFailedPrecondition, "negative"));
}

TEST(StatusTest, NestedReturnIfErrorReturnsTheInnerError) {
  std::vector<std::string> steps;
  ASSERT_THAT(Nested(false, &steps), IsOk());
  EXPECT_EQ(steps, (std::vector<std::string>{"begin", "a", "b", "c", "commit", "after"}));

  steps.clear();
  const Status failed = Nested(true, &steps);
  EXPECT_EQ(failed.code(), StatusCode::kAborted);
  EXPECT_EQ(failed.message(), "b failed");
  EXPECT_EQ(steps, (std::vector<std::string>{"begin", "a"}));  // neither c, the commit nor the rest ran
}

TEST(StatusMatchersTest, IsOkOnStatusAndResult) {
  EXPECT_THAT(Status::Ok(), IsOk());
  EXPECT_THAT(Result<int>(3), IsOk());
  EXPECT_THAT(NotFound("robot r1"), Not(IsOk()));
  EXPECT_THAT(Result<int>(DataLoss("crc")), Not(IsOk()));
}

TEST(StatusMatchersTest, FailingIsOkNamesTheCodeAndMessage) {
  ::testing::StringMatchResultListener listener;
  EXPECT_FALSE(::testing::ExplainMatchResult(IsOk(), NotFound("robot r1"), &listener));
  EXPECT_EQ(listener.str(), "which is NOT_FOUND: robot r1");

  ::testing::StringMatchResultListener result_listener;
  EXPECT_FALSE(
      ::testing::ExplainMatchResult(IsOk(), Result<std::string>(DataLoss("checksum")), &result_listener));
  EXPECT_EQ(result_listener.str(), "which is DATA_LOSS: checksum");

  // What a test run prints: the value (the status) and the explanation.
  EXPECT_NONFATAL_FAILURE(EXPECT_THAT(Result<int>(Unavailable("database busy")), IsOk()),
                          "UNAVAILABLE: database busy");
  EXPECT_NONFATAL_FAILURE(EXPECT_THAT(Internal("solver diverged"), IsOk()), "Expected: is OK");
}

TEST(StatusMatchersTest, StatusIsChecksCodeAndMessage) {
  const Status status = FailedPrecondition("time went backwards at event 12");
  EXPECT_THAT(status, StatusIs(StatusCode::kFailedPrecondition));
  EXPECT_THAT(status, StatusIs(StatusCode::kFailedPrecondition, "backwards"));
  EXPECT_THAT(status, StatusIs(StatusCode::kFailedPrecondition, std::string("event 12")));
  EXPECT_THAT(status, StatusIs(StatusCode::kFailedPrecondition, StartsWith("time")));
  EXPECT_THAT(status, Not(StatusIs(StatusCode::kInvalidArgument)));
  EXPECT_THAT(status, Not(StatusIs(StatusCode::kFailedPrecondition, "forwards")));
  EXPECT_THAT(Result<int>(1), StatusIs(StatusCode::kOk));
  EXPECT_THAT(Result<int>(AlreadyExists("run r1")), StatusIs(StatusCode::kAlreadyExists, HasSubstr("r1")));

  EXPECT_EQ(::testing::DescribeMatcher<Status>(StatusIs(StatusCode::kNotFound, "r1")),
            "has code NOT_FOUND and a message that has substring \"r1\"");
  ::testing::StringMatchResultListener wrong_code;
  EXPECT_FALSE(::testing::ExplainMatchResult(StatusIs(StatusCode::kNotFound), status, &wrong_code));
  EXPECT_EQ(wrong_code.str(), "which is FAILED_PRECONDITION: time went backwards at event 12");
  ::testing::StringMatchResultListener wrong_message;
  EXPECT_FALSE(::testing::ExplainMatchResult(StatusIs(StatusCode::kFailedPrecondition, "forwards"), status,
                                             &wrong_message));
  EXPECT_THAT(wrong_message.str(), HasSubstr("FAILED_PRECONDITION: time went backwards"));
  ::testing::StringMatchResultListener ok_is_not_an_error;
  EXPECT_FALSE(
      ::testing::ExplainMatchResult(StatusIs(StatusCode::kNotFound), Status::Ok(), &ok_is_not_an_error));
  EXPECT_EQ(ok_is_not_an_error.str(), "which is OK");
}

}  // namespace
}  // namespace slamcore
