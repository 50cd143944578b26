// Bounds on uploads in flight: how many Ingest.UploadRun streams may be open, and how many bytes they may
// hold buffered, per principal and in all. A stream is admitted when it starts (after authentication) and
// reserves the bytes of each message as it is read; the reservation ends with the call (after storing).
// A refusal is RESOURCE_EXHAUSTED naming the limit: it is temporary (other uploads finish), so clients
// retry it. Limits are validated so that one run within --max-run-bytes always fits when it is alone.
// Besides what is reserved, gRPC holds at most one incoming message (--max-message-bytes) per stream.
//
// Thread safety: IngestAdmission is safe to use from many threads (one mutex); a Ticket belongs to one call.
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <mutex>
#include <string>
#include <unordered_map>

namespace server {

struct IngestAdmissionLimits {
  int max_streams = 64;                                // --max-upload-streams
  int max_streams_per_principal = 4;                   // --max-upload-streams-per-principal
  std::int64_t max_bytes = 1LL << 30;                  // --max-upload-bytes-in-flight
  std::int64_t max_bytes_per_principal = 512LL << 20;  // --max-upload-bytes-per-principal
};

class IngestAdmission {
 public:
  explicit IngestAdmission(const IngestAdmissionLimits& limits) : limits_(limits) {}

  /// One admitted stream; releases its stream slot and bytes when destroyed.
  class Ticket {
   public:
    Ticket() = default;
    Ticket(const Ticket&) = delete;
    Ticket& operator=(const Ticket&) = delete;
    ~Ticket();
    /// Reserves `bytes` more for this stream; RESOURCE_EXHAUSTED (nothing reserved) past a limit.
    grpc::Status Reserve(std::int64_t bytes);

   private:
    friend class IngestAdmission;
    IngestAdmission* admission_ = nullptr;
    std::string principal_;
    std::int64_t bytes_ = 0;
  };

  /// Admits a new stream of `principal` into `ticket` (which must be empty), or RESOURCE_EXHAUSTED.
  grpc::Status Admit(const std::string& principal, Ticket& ticket);

  /// Current totals (metrics, tests).
  int streams() const;
  std::int64_t bytes() const;

 private:
  struct Usage {
    int streams = 0;
    std::int64_t bytes = 0;
  };
  void Release(const std::string& principal, std::int64_t bytes);

  const IngestAdmissionLimits limits_;
  mutable std::mutex mutex_;  // guards total_, by_principal_
  Usage total_;
  std::unordered_map<std::string, Usage> by_principal_;
};

}  // namespace server
