// Reprocessing: parameter sets (immutable by name) and reprocessing jobs over a run filter, with progress,
// cancellation and a server-streaming watch.
#pragma once

#include "fleet/v1/service.grpc.pb.h"
#include "service_context.h"

namespace server {

class ReprocessingHandler final : public fleet::v1::Reprocessing::Service {
 public:
  explicit ReprocessingHandler(ServiceContext& context) : context_(context) {}
  grpc::Status PutParameterSet(grpc::ServerContext* call, const fleet::v1::PutParameterSetRequest* request,
                               fleet::v1::PutParameterSetResponse* response) override;
  grpc::Status ListParameterSets(grpc::ServerContext* call,
                                 const fleet::v1::ListParameterSetsRequest* request,
                                 fleet::v1::ListParameterSetsResponse* response) override;
  grpc::Status StartJob(grpc::ServerContext* call, const fleet::v1::StartJobRequest* request,
                        fleet::v1::Job* response) override;
  grpc::Status GetJob(grpc::ServerContext* call, const fleet::v1::GetJobRequest* request,
                      fleet::v1::Job* response) override;
  grpc::Status ListJobs(grpc::ServerContext* call, const fleet::v1::ListJobsRequest* request,
                        fleet::v1::ListJobsResponse* response) override;
  grpc::Status CancelJob(grpc::ServerContext* call, const fleet::v1::CancelJobRequest* request,
                         fleet::v1::Job* response) override;
  grpc::Status WatchJob(grpc::ServerContext* call, const fleet::v1::GetJobRequest* request,
                        grpc::ServerWriter<fleet::v1::Job>* writer) override;

  /// Stores `set` after validating it (INVALID_ARGUMENT naming the field). Also used at startup for the
  /// default set.
  static grpc::Status StoreParameterSet(storage::Repository& repository, const fleet::v1::ParameterSet& set,
                                        const std::string& field, bool* already_present);

 private:
  grpc::Status LoadJob(std::int64_t job_id, fleet::v1::Job* job);
  ServiceContext& context_;
};

}  // namespace server
