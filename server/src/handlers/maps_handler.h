// Maps: each robot's map history, findings, repairs and reviews for engineers; GetMap and StreamMap (the same
// answer in parts) for robots (their own map only); export as map_server files or g2o. The work is
// MapHistory's (server/map_history.h).
#pragma once

#include <cstdint>

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
  grpc::Status ListRobots(grpc::ServerContext* call, const fleet::v1::ListRobotsRequest* request,
                          fleet::v1::ListRobotsResponse* response) override;
  grpc::Status GetMapVersion(grpc::ServerContext* call, const fleet::v1::GetMapVersionRequest* request,
                             fleet::v1::GetMapVersionResponse* response) override;
  grpc::Status RepairMap(grpc::ServerContext* call, const fleet::v1::RepairMapRequest* request,
                         fleet::v1::RepairMapResponse* response) override;
  grpc::Status ReviewMapVersion(grpc::ServerContext* call, const fleet::v1::ReviewMapVersionRequest* request,
                                fleet::v1::MapVersion* response) override;
  grpc::Status GetMap(grpc::ServerContext* call, const fleet::v1::GetMapRequest* request,
                      fleet::v1::GetMapResponse* response) override;
  grpc::Status StreamMap(grpc::ServerContext* call, const fleet::v1::GetMapRequest* request,
                         grpc::ServerWriter<fleet::v1::GetMapResponse>* writer) override;
  grpc::Status ExportMap(grpc::ServerContext* call, const fleet::v1::ExportMapRequest* request,
                         fleet::v1::ExportMapResponse* response) override;
  grpc::Status ImportMap(grpc::ServerContext* call, const fleet::v1::ImportMapRequest* request,
                         fleet::v1::ImportMapResponse* response) override;

 private:
  // StreamMap's bounds on a message's snapshot part; the default fits gRPC's default receive limit (4 MiB).
  static constexpr std::int64_t kMinMapPartBytes = 16 << 10;
  static constexpr std::int64_t kMaxMapPartBytes = 16 << 20;
  static constexpr std::int64_t kDefaultMapPartBytes = 1 << 20;

  // GetMap's answer, whole: who asks and what they may see (a robot: its own map only), then the current version.
  grpc::Status AnswerMapRequest(grpc::ServerContext* call, const fleet::v1::GetMapRequest& request,
                                bool streamed, fleet::v1::GetMapResponse* response);

  ServiceContext& context_;
  MapHistory history_;
};

}  // namespace server
