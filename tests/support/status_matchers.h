// gMock matchers for the project's Status and Result<T> (slamcore/status.h), which say what the error was when
// they fail (ASSERT_TRUE(x.ok()) only says "false"):
//
//   ASSERT_THAT(repository.PutRun(run), IsOk());
//   EXPECT_THAT(mapper.Process(event), StatusIs(StatusCode::kFailedPrecondition, "backwards"));
//
// IsOk() also takes grpc::Status (anything with ok(), error_code() and error_message()) without this header
// knowing gRPC. StatusIs' second argument is a substring, or any matcher of std::string.
// Target status_matchers (header only; gMock and slamcore_status).
#pragma once

#include <gmock/gmock.h>

#include <ostream>
#include <string>
#include <type_traits>
#include <utility>

#include "slamcore/status.h"

namespace slamcore {

// gtest prints values with these (found by argument-dependent lookup), so a failing EXPECT shows the status.
inline void PrintTo(const Status& status, std::ostream* os) { *os << status.ToString(); }
template <typename T>
void PrintTo(const Result<T>& result, std::ostream* os) {
  *os << (result.ok() ? std::string("OK (a value)") : result.status().ToString());
}

}  // namespace slamcore

namespace status_testing {
namespace internal {

inline const slamcore::Status& StatusOf(const slamcore::Status& status) { return status; }
template <typename T>
const slamcore::Status& StatusOf(const slamcore::Result<T>& result) {
  return result.status();
}

// "NOT_FOUND: run r1 of robot a", or for gRPC's status its numeric code and message.
template <typename T>
std::string Describe(const T& value) {
  if constexpr (requires { StatusOf(value); }) {
    return StatusOf(value).ToString();
  } else if constexpr (requires {
                         value.error_code();
                         value.error_message();
                       }) {
    return "gRPC code " + std::to_string(static_cast<int>(value.error_code())) + ": " +
           std::string(value.error_message());
  } else {
    return "not OK";
  }
}

class IsOkMatcher {
 public:
  template <typename T>
  bool MatchAndExplain(const T& value, ::testing::MatchResultListener* listener) const {
    if (value.ok()) return true;
    *listener << "which is " << Describe(value);
    return false;
  }
  void DescribeTo(std::ostream* os) const { *os << "is OK"; }
  void DescribeNegationTo(std::ostream* os) const { *os << "is not OK"; }
};

class StatusIsMatcher {
 public:
  StatusIsMatcher(slamcore::StatusCode code, ::testing::Matcher<const std::string&> message)
      : code_(code), message_(std::move(message)) {}

  template <typename T>
  bool MatchAndExplain(const T& value, ::testing::MatchResultListener* listener) const {
    const slamcore::Status& status = StatusOf(value);
    if (status.code() != code_) {
      *listener << "which is " << (status.ok() ? std::string("OK") : status.ToString());
      return false;
    }
    ::testing::StringMatchResultListener inner;
    if (!message_.MatchAndExplain(status.message(), &inner)) {
      *listener << "which is " << status.ToString();
      if (!inner.str().empty()) *listener << ", whose message " << inner.str();
      return false;
    }
    return true;
  }
  void DescribeTo(std::ostream* os) const {
    *os << "has code " << slamcore::StatusCodeName(code_) << " and a message that ";
    message_.DescribeTo(os);
  }
  void DescribeNegationTo(std::ostream* os) const {
    *os << "does not have code " << slamcore::StatusCodeName(code_) << " or has a message that ";
    message_.DescribeNegationTo(os);
  }

 private:
  slamcore::StatusCode code_;
  ::testing::Matcher<const std::string&> message_;
};

}  // namespace internal

/// Status, Result<T> or grpc::Status is OK; on failure prints the code and message.
inline ::testing::PolymorphicMatcher<internal::IsOkMatcher> IsOk() {
  return ::testing::MakePolymorphicMatcher(internal::IsOkMatcher());
}

/// Status or Result<T> has `code` (any message).
inline ::testing::PolymorphicMatcher<internal::StatusIsMatcher> StatusIs(slamcore::StatusCode code) {
  return ::testing::MakePolymorphicMatcher(internal::StatusIsMatcher(code, ::testing::_));
}

/// Status or Result<T> has `code` and a message containing `substring`.
inline ::testing::PolymorphicMatcher<internal::StatusIsMatcher> StatusIs(slamcore::StatusCode code,
                                                                         const char* substring) {
  return ::testing::MakePolymorphicMatcher(internal::StatusIsMatcher(code, ::testing::HasSubstr(substring)));
}
inline ::testing::PolymorphicMatcher<internal::StatusIsMatcher> StatusIs(slamcore::StatusCode code,
                                                                         const std::string& substring) {
  return StatusIs(code, substring.c_str());
}

/// Status or Result<T> has `code` and a message `message_matcher` matches (e.g. StartsWith("run ")).
template <typename MessageMatcher>
requires(!std::is_convertible_v<MessageMatcher, std::string>)::testing::PolymorphicMatcher<
    internal::StatusIsMatcher> StatusIs(slamcore::StatusCode code, MessageMatcher message_matcher) {
  return ::testing::MakePolymorphicMatcher(
      internal::StatusIsMatcher(code, ::testing::SafeMatcherCast<const std::string&>(message_matcher)));
}

}  // namespace status_testing

using ::status_testing::IsOk;
using ::status_testing::StatusIs;
