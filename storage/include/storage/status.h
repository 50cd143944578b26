// Status and Result: how storage reports failures caused by data, the database or the caller.
// Corrupt or conflicting data is a Status, never a crash and never returned as if it were data.
// (Same shape as slamcore's Status, kept separate because storage must not depend on slamcore.)
//
// Thread safety: value types.
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace storage {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,     // the caller's data is malformed or out of range
  kNotFound,            // the requested record does not exist
  kAlreadyExists,       // a record with this key exists with different content (a conflict)
  kFailedPrecondition,  // valid request, wrong state (lease lost, schema too new, missing referenced record)
  kAborted,             // a concurrent change came first (e.g. a map's newest version moved); read again, retry
  kDataLoss,            // stored data is corrupt (checksum mismatch, not a database)
  kUnavailable,         // the database is busy or unreachable; retrying may help
  kInternal,            // a dependency failed unexpectedly
};

const char* StatusCodeName(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status Ok() { return {}; }
  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  /// "DATA_LOSS: <message>", or "OK".
  std::string ToString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status InvalidArgument(std::string message) { return {StatusCode::kInvalidArgument, std::move(message)}; }
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
  Result(T value) : storage_(std::move(value)) {}  // NOLINT(google-explicit-constructor)
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

}  // namespace storage

#define STORAGE_STATUS_CONCAT_INNER_(a, b) a##b
#define STORAGE_STATUS_CONCAT_(a, b) STORAGE_STATUS_CONCAT_INNER_(a, b)

/// Returns the status from the enclosing function when it is an error. The variable is named after the line
/// so that nested uses (a transaction body inside a checked call) do not shadow each other.
#define STORAGE_RETURN_IF_ERROR(expr)                                                        \
  do {                                                                                       \
    ::storage::Status STORAGE_STATUS_CONCAT_(storage_status_, __LINE__) = (expr);            \
    if (!STORAGE_STATUS_CONCAT_(storage_status_, __LINE__).ok())                             \
      return STORAGE_STATUS_CONCAT_(storage_status_, __LINE__);                              \
  } while (false)
