// Status and Result: how every part of the project (slamcore, storage, analyzer, server, tools) reports failures
// caused by data, the database or the caller. Data never crashes the library; programmer errors are asserts.
// The one definition: target slamcore_status depends on the standard library only, so it builds for a robot and
// storage links it without the rest of slamcore.
//
// Thread safety: value types.
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace slamcore {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,  // the caller's data is malformed or out of range, whatever the state (retrying won't help)
  kNotFound,         // a referenced id, record or file does not exist
  kAlreadyExists,    // a record with this key exists with different content (a conflict on create)
  kFailedPrecondition,  // valid data, wrong state: time going backwards, lease lost, schema too new,
                        // a referenced record missing; the caller must change the state first
  kAborted,      // a concurrent change came first (e.g. a map's newest version moved); read again, retry
  kDataLoss,     // stored or received data is corrupt (checksum mismatch, does not parse, not a database)
  kUnavailable,  // a service or the database is busy or unreachable; retrying later may help
  kInternal,     // a dependency failed unexpectedly; a bug or an environment problem, not the caller's
};

/// "INVALID_ARGUMENT", ... (the gRPC spelling).
const char* StatusCodeName(StatusCode code);

/// A number as an error message shows it: the shortest of %g's forms ("0.05", "1e-09"), where
/// std::to_string prints six fixed decimals ("0.000000" for 1e-9).
std::string MessageNumber(double value);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status Ok() { return {}; }
  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  /// "INVALID_ARGUMENT: <message>", or "OK".
  std::string ToString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status InvalidArgument(std::string message) {
  return {StatusCode::kInvalidArgument, std::move(message)};
}
inline Status NotFound(std::string message) { return {StatusCode::kNotFound, std::move(message)}; }
inline Status AlreadyExists(std::string message) { return {StatusCode::kAlreadyExists, std::move(message)}; }
inline Status FailedPrecondition(std::string message) {
  return {StatusCode::kFailedPrecondition, std::move(message)};
}
inline Status Aborted(std::string message) { return {StatusCode::kAborted, std::move(message)}; }
inline Status DataLoss(std::string message) { return {StatusCode::kDataLoss, std::move(message)}; }
inline Status Unavailable(std::string message) { return {StatusCode::kUnavailable, std::move(message)}; }
inline Status Internal(std::string message) { return {StatusCode::kInternal, std::move(message)}; }

/// A value or the Status that explains why there is none.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : storage_(std::move(value)) {}        // NOLINT(google-explicit-constructor)
  Result(Status status) : storage_(std::move(status)) {  // NOLINT(google-explicit-constructor)
    assert(!std::get<Status>(storage_).ok() && "a Result needs a value or an error");
  }

  bool ok() const { return std::holds_alternative<T>(storage_); }
  const Status& status() const {
    static const Status kOk;
    return ok() ? kOk : std::get<Status>(storage_);
  }
  const T& value() const& { return std::get<T>(storage_); }
  T& value() & { return std::get<T>(storage_); }
  T&& value() && { return std::get<T>(std::move(storage_)); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

 private:
  std::variant<T, Status> storage_;
};

}  // namespace slamcore

// The temporaries are named after the line so that nested uses (a transaction body inside a checked call) do
// not shadow each other.
#define SLAMCORE_STATUS_CONCAT_INNER_(a, b) a##b
#define SLAMCORE_STATUS_CONCAT_(a, b) SLAMCORE_STATUS_CONCAT_INNER_(a, b)

/// Returns the Status `expr` evaluates to from the enclosing function when it is an error. (A copy, not a
/// reference: `expr` may be `Call().status()`, a reference into a temporary.)
#define RETURN_IF_ERROR(expr)                                                                                \
  do {                                                                                                       \
    ::slamcore::Status SLAMCORE_STATUS_CONCAT_(status_, __LINE__) = (expr);                                  \
    if (!SLAMCORE_STATUS_CONCAT_(status_, __LINE__).ok()) return SLAMCORE_STATUS_CONCAT_(status_, __LINE__); \
  } while (false)

/// Evaluates `expr` (a Result<T>); returns its Status from the enclosing function when it is an error, else
/// moves the value into `lhs`: a declaration (`auto x`, `Map map`) or an existing variable. Expands to several
/// statements, so it cannot be the body of an unbraced if.
#define ASSIGN_OR_RETURN(lhs, expr) \
  SLAMCORE_ASSIGN_OR_RETURN_IMPL_(SLAMCORE_STATUS_CONCAT_(result_, __LINE__), lhs, expr)
#define SLAMCORE_ASSIGN_OR_RETURN_IMPL_(result, lhs, expr) \
  auto result = (expr);                                    \
  if (!result.ok()) return result.status();                \
  lhs = std::move(result).value()
