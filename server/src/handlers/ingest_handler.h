// Ingest.UploadRun: accumulate one run's stream, validate every part (naming the field), store snapshots
// and the run idempotently by run id, enqueue its analysis. A stream that fails or is cut stores no run.
#pragma once

#include "fleet/v1/service.grpc.pb.h"
#include "service_context.h"

namespace server {

class IngestHandler final : public fleet::v1::Ingest::Service {
 public:
  explicit IngestHandler(ServiceContext& context) : context_(context) {}
  grpc::Status UploadRun(grpc::ServerContext* call, grpc::ServerReader<fleet::v1::UploadRunRequest>* reader,
                         fleet::v1::UploadRunResponse* response) override;

 private:
  grpc::Status Upload(grpc::ServerContext* call, grpc::ServerReader<fleet::v1::UploadRunRequest>* reader,
                      fleet::v1::UploadRunResponse* response);
  ServiceContext& context_;
};

}  // namespace server
