// Queries: run reports, run listings with keyset pagination, fleet statistics (the paper's figures, total
// and grouped for trends), and run-by-run comparison of two parameter sets.
#pragma once

#include "fleet/v1/service.grpc.pb.h"
#include "server/fleet_queries.h"
#include "service_context.h"

namespace server {

class QueriesHandler final : public fleet::v1::Queries::Service {
 public:
  explicit QueriesHandler(ServiceContext& context)
      : context_(context), queries_(*context.repository, context.default_parameter_set) {}
  grpc::Status GetRunReport(grpc::ServerContext* call, const fleet::v1::GetRunReportRequest* request,
                            fleet::v1::GetRunReportResponse* response) override;
  grpc::Status ListRuns(grpc::ServerContext* call, const fleet::v1::ListRunsRequest* request,
                        fleet::v1::ListRunsResponse* response) override;
  grpc::Status GetFleetStatistics(grpc::ServerContext* call,
                                  const fleet::v1::GetFleetStatisticsRequest* request,
                                  fleet::v1::GetFleetStatisticsResponse* response) override;
  grpc::Status CompareParameterSets(grpc::ServerContext* call,
                                    const fleet::v1::CompareParameterSetsRequest* request,
                                    fleet::v1::CompareParameterSetsResponse* response) override;

 private:
  grpc::Status DoGetRunReport(grpc::ServerContext* call, const fleet::v1::GetRunReportRequest* request,
                              fleet::v1::GetRunReportResponse* response);
  grpc::Status DoListRuns(grpc::ServerContext* call, const fleet::v1::ListRunsRequest* request,
                          fleet::v1::ListRunsResponse* response);
  grpc::Status DoStatistics(grpc::ServerContext* call, const fleet::v1::GetFleetStatisticsRequest* request,
                            fleet::v1::GetFleetStatisticsResponse* response);
  grpc::Status DoCompare(grpc::ServerContext* call, const fleet::v1::CompareParameterSetsRequest* request,
                         fleet::v1::CompareParameterSetsResponse* response);
  ServiceContext& context_;
  FleetQueries queries_;
};

}  // namespace server
