#include "fleet_client/uploader.h"

#include <grpcpp/grpcpp.h>
#include <openssl/sha.h>

#include <fstream>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>
#include <unordered_set>

#include "fleet/serialization.h"
#include "fleet/snapshot_parts.h"
#include "fleet/status_codes.h"
#include "fleet/v1/service.grpc.pb.h"
#include "fleet_client/channel.h"

namespace fleet_client {

bool RetryableUpload(int code, const std::string& message) {
  switch (static_cast<grpc::StatusCode>(code)) {
    case grpc::StatusCode::UNAVAILABLE:
    case grpc::StatusCode::DEADLINE_EXCEEDED:
    case grpc::StatusCode::ABORTED: return true;
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      // gRPC itself refuses a message over the peer's size limit with this code; it never fits.
      return message.find("larger than max") == std::string::npos;
    default: return false;
  }
}

std::optional<std::string> ReadTokenFile(const std::string& path, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = "token file " + path + ": cannot read it";
    return std::nullopt;
  }
  std::ostringstream text;
  text << in.rdbuf();
  std::string token = text.str();
  token.erase(0, token.find_first_not_of(" \t\r\n"));
  token.erase(token.find_last_not_of(" \t\r\n") + 1);
  if (token.empty() || token.size() > 512) {
    *error = "token file " + path + ": expected one token of 1..512 characters";
    return std::nullopt;
  }
  if (token.find_first_of(" \t\r\n") != std::string::npos) {
    *error = "token file " + path + ": expected one token on one line";
    return std::nullopt;
  }
  return token;
}

std::string SnapshotId(const fleet::v1::MapSnapshot& snapshot) {
  const std::string bytes = fleet::SerializeDeterministic(snapshot);
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), digest);
  static const char* kDigits = "0123456789abcdef";
  std::string hex;
  for (unsigned char byte : digest) {
    hex.push_back(kDigits[byte >> 4]);
    hex.push_back(kDigits[byte & 15]);
  }
  return hex;
}

class Uploader::Impl {
 public:
  explicit Impl(const UploaderOptions& options) : options_(options) {
    stub_ = fleet::v1::Ingest::NewStub(CreateFleetChannel(options.server, options.tls_ca, 64 << 20));
  }

  UploadOutcome Upload(const fleet::v1::RunFile& run) {
    UploadOutcome outcome;
    outcome.run_id = run.header().run_id();
    const auto started = std::chrono::steady_clock::now();
    // Name the parent by id when the server holds it (it was our previous run's child): no need to send it.
    std::string parent_id;
    bool parent_known = false;
    if (run.parent_snapshot().nodes_size() > 0) {
      parent_id = SnapshotId(run.parent_snapshot());
      std::lock_guard lock(mutex_);
      parent_known = known_.contains(parent_id);
    }
    std::chrono::milliseconds backoff = options_.initial_backoff;
    std::mt19937 random(std::random_device{}());
    for (int attempt = 1; attempt <= options_.max_attempts; ++attempt) {
      outcome.attempts = attempt;
      fleet::v1::UploadRunResponse response;
      grpc::Status status = Attempt(run, parent_id, parent_known, &response);
      if (status.error_code() == grpc::StatusCode::FAILED_PRECONDITION && parent_known) {
        parent_known = false;  // the server lost (or never had) it: send it
        status = Attempt(run, parent_id, false, &response);
      }
      outcome.code = static_cast<int>(status.error_code());
      if (status.ok()) {
        outcome.ok = true;
        outcome.already_present = response.already_present();
        outcome.child_snapshot_id = response.child_snapshot_id();
        outcome.events = response.events_stored();
        outcome.analysis_job_id = response.analysis_job_id();
        outcome.map_version = response.map_version();
        outcome.current_map_version = response.current_map_version();
        outcome.map_outdated = response.map_outdated();
        std::lock_guard lock(mutex_);
        known_.insert(response.child_snapshot_id());
        if (!response.parent_snapshot_id().empty()) known_.insert(response.parent_snapshot_id());
        break;
      }
      outcome.message = std::string(fleet::GrpcCodeName(status.error_code())) + ": " + status.error_message();
      if (!RetryableUpload(status.error_code(), status.error_message()) || attempt == options_.max_attempts)
        break;
      std::uniform_int_distribution<long> jitter(0, backoff.count() / 2);
      std::this_thread::sleep_for(backoff + std::chrono::milliseconds(jitter(random)));
      backoff = std::min(backoff * 2, std::chrono::milliseconds(10000));
    }
    outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return outcome;
  }

 private:
  grpc::Status Attempt(const fleet::v1::RunFile& run, const std::string& parent_id, bool parent_known,
                       fleet::v1::UploadRunResponse* response) {
    grpc::ClientContext context;
    context.AddMetadata("authorization", "Bearer " + options_.token);
    context.set_deadline(std::chrono::system_clock::now() +
                         std::chrono::milliseconds(static_cast<long long>(options_.deadline_seconds * 1000)));
    auto writer = stub_->UploadRun(&context, response);
    fleet::v1::UploadRunRequest message;
    *message.mutable_header() = run.header();
    if (!parent_id.empty()) message.mutable_header()->set_parent_snapshot_id(parent_id);
    bool open = writer->Write(message);
    const int chunk = std::max(1, options_.events_per_chunk);
    for (int i = 0; open && i < run.events_size(); i += chunk) {
      message.Clear();
      auto* events = message.mutable_events()->mutable_events();
      const int end = std::min(run.events_size(), i + chunk);
      events->Reserve(end - i);
      for (int j = i; j < end; ++j) *events->Add() = run.events(j);
      open = writer->Write(message);
    }
    // Each snapshot in parts, into the message's `slot` (parent_snapshot or child_snapshot).
    const auto send_in_parts = [&](const fleet::v1::MapSnapshot& snapshot,
                                   fleet::v1::MapSnapshot* (fleet::v1::UploadRunRequest::*slot)()) {
      for (fleet::v1::MapSnapshot& part : fleet::SnapshotParts(snapshot, options_.snapshot_part_bytes)) {
        message.Clear();
        *(message.*slot)() = std::move(part);
        if (!(open = writer->Write(message))) return;
      }
    };
    if (open && !parent_known && run.parent_snapshot().nodes_size() > 0)
      send_in_parts(run.parent_snapshot(), &fleet::v1::UploadRunRequest::mutable_parent_snapshot);
    if (open) send_in_parts(run.child_snapshot(), &fleet::v1::UploadRunRequest::mutable_child_snapshot);
    if (open) writer->WritesDone();
    return writer->Finish();
  }

  const UploaderOptions options_;
  std::unique_ptr<fleet::v1::Ingest::Stub> stub_;
  std::mutex mutex_;                       // guards known_
  std::unordered_set<std::string> known_;  // snapshot ids the server confirmed
};

Uploader::Uploader(const UploaderOptions& options) : impl_(std::make_unique<Impl>(options)) {}
Uploader::~Uploader() = default;
UploadOutcome Uploader::Upload(const fleet::v1::RunFile& run) { return impl_->Upload(run); }

}  // namespace fleet_client
