#include "ingest_admission.h"

namespace server {

grpc::Status IngestAdmission::Admit(const std::string& principal, Ticket& ticket) {
  std::lock_guard lock(mutex_);
  Usage& mine = by_principal_[principal];
  if (mine.streams >= limits_.max_streams_per_principal) {
    return {grpc::StatusCode::RESOURCE_EXHAUSTED,
            principal + " has " + std::to_string(mine.streams) + " uploads in flight, the most allowed " +
                "(max_upload_streams_per_principal " + std::to_string(limits_.max_streams_per_principal) +
                "); retry when one has finished"};
  }
  if (total_.streams >= limits_.max_streams) {
    if (mine.streams == 0 && mine.bytes == 0) by_principal_.erase(principal);
    return {grpc::StatusCode::RESOURCE_EXHAUSTED,
            "the server has " + std::to_string(total_.streams) + " uploads in flight, the most allowed " +
                "(max_upload_streams " + std::to_string(limits_.max_streams) + "); retry later"};
  }
  ++mine.streams;
  ++total_.streams;
  ticket.admission_ = this;
  ticket.principal_ = principal;
  return grpc::Status::OK;
}

grpc::Status IngestAdmission::Ticket::Reserve(std::int64_t bytes) {
  std::lock_guard lock(admission_->mutex_);
  const IngestAdmissionLimits& limits = admission_->limits_;
  Usage& mine = admission_->by_principal_[principal_];
  if (mine.bytes + bytes > limits.max_bytes_per_principal) {
    return {grpc::StatusCode::RESOURCE_EXHAUSTED, principal_ + "'s uploads in flight would hold " +
                                                      std::to_string(mine.bytes + bytes) +
                                                      " bytes, more than max_upload_bytes_per_principal (" +
                                                      std::to_string(limits.max_bytes_per_principal) +
                                                      "); retry when its other uploads have finished"};
  }
  if (admission_->total_.bytes + bytes > limits.max_bytes) {
    return {grpc::StatusCode::RESOURCE_EXHAUSTED, "uploads in flight would hold " +
                                                      std::to_string(admission_->total_.bytes + bytes) +
                                                      " bytes, more than max_upload_bytes_in_flight (" +
                                                      std::to_string(limits.max_bytes) + "); retry later"};
  }
  mine.bytes += bytes;
  admission_->total_.bytes += bytes;
  bytes_ += bytes;
  return grpc::Status::OK;
}

IngestAdmission::Ticket::~Ticket() {
  if (admission_ != nullptr) admission_->Release(principal_, bytes_);
}

void IngestAdmission::Release(const std::string& principal, std::int64_t bytes) {
  std::lock_guard lock(mutex_);
  auto it = by_principal_.find(principal);
  if (it == by_principal_.end()) return;
  it->second.streams -= 1;
  it->second.bytes -= bytes;
  total_.streams -= 1;
  total_.bytes -= bytes;
  if (it->second.streams == 0) by_principal_.erase(it);
}

int IngestAdmission::streams() const {
  std::lock_guard lock(mutex_);
  return total_.streams;
}

std::int64_t IngestAdmission::bytes() const {
  std::lock_guard lock(mutex_);
  return total_.bytes;
}

}  // namespace server
