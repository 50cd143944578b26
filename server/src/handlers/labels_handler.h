// Labels: list the protrusion regions of a run's report and label one ("protrusion" or "new_space").
#pragma once

#include "fleet/v1/service.grpc.pb.h"
#include "service_context.h"

namespace server {

class LabelsHandler final : public fleet::v1::Labels::Service {
 public:
  explicit LabelsHandler(ServiceContext& context) : context_(context) {}
  grpc::Status ListRegions(grpc::ServerContext* call, const fleet::v1::ListRegionsRequest* request,
                           fleet::v1::ListRegionsResponse* response) override;
  grpc::Status LabelRegion(grpc::ServerContext* call, const fleet::v1::LabelRegionRequest* request,
                           fleet::v1::LabelRegionResponse* response) override;

 private:
  grpc::Status ReportMissing(const storage::RunKey& run, const std::string& set);
  ServiceContext& context_;
};

}  // namespace server
