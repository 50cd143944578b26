// Maps: each robot's map history, findings, repairs and reviews for engineers; GetMap for robots (their own
// map only); export as map_server files or g2o. The work is MapHistory's (server/map_history.h).
#pragma once

#include "fleet/v1/service.grpc.pb.h"
#include "server/map_history.h"
#include "service_context.h"

namespace server {

class MapsHandler final : public fleet::v1::Maps::Service {
 public:
  explicit MapsHandler(ServiceContext& context)
      : context_(context), history_(*context.repository, context.map_policy) {}
  grpc::Status ListMapVersions(grpc::ServerContext* call, const fleet::v1::ListMapVersionsRequest* request,
                               fleet::v1::ListMapVersionsResponse* response) override;
  grpc::Status GetMapVersion(grpc::ServerContext* call, const fleet::v1::GetMapVersionRequest* request,
                             fleet::v1::GetMapVersionResponse* response) override;
  grpc::Status RepairMap(grpc::ServerContext* call, const fleet::v1::RepairMapRequest* request,
                         fleet::v1::RepairMapResponse* response) override;
  grpc::Status ReviewMapVersion(grpc::ServerContext* call, const fleet::v1::ReviewMapVersionRequest* request,
                                fleet::v1::MapVersion* response) override;
  grpc::Status GetMap(grpc::ServerContext* call, const fleet::v1::GetMapRequest* request,
                      fleet::v1::GetMapResponse* response) override;
  grpc::Status ExportMap(grpc::ServerContext* call, const fleet::v1::ExportMapRequest* request,
                         fleet::v1::ExportMapResponse* response) override;
  grpc::Status ImportMap(grpc::ServerContext* call, const fleet::v1::ImportMapRequest* request,
                         fleet::v1::ImportMapResponse* response) override;

 private:
  ServiceContext& context_;
  MapHistory history_;
};

}  // namespace server
