// Models: train a protrusion classifier (slamcore's, paper IV-C) from labelled regions, evaluate a version
// on labelled regions, activate a version (workers then classify new reports with it), list versions.
#pragma once

#include <mutex>

#include "fleet/v1/service.grpc.pb.h"
#include "service_context.h"

namespace server {

class ModelsHandler final : public fleet::v1::Models::Service {
 public:
  explicit ModelsHandler(ServiceContext& context) : context_(context) {}
  grpc::Status TrainModel(grpc::ServerContext* call, const fleet::v1::TrainModelRequest* request,
                          fleet::v1::TrainModelResponse* response) override;
  grpc::Status EvaluateModel(grpc::ServerContext* call, const fleet::v1::EvaluateModelRequest* request,
                             fleet::v1::EvaluateModelResponse* response) override;
  grpc::Status ActivateModel(grpc::ServerContext* call, const fleet::v1::ActivateModelRequest* request,
                             fleet::v1::Model* response) override;
  grpc::Status ListModels(grpc::ServerContext* call, const fleet::v1::ListModelsRequest* request,
                          fleet::v1::ListModelsResponse* response) override;

 private:
  grpc::Status DoTrain(const fleet::v1::TrainModelRequest* request, fleet::v1::TrainModelResponse* response);
  grpc::Status DoEvaluate(const fleet::v1::EvaluateModelRequest* request,
                          fleet::v1::EvaluateModelResponse* response);
  ServiceContext& context_;
  std::mutex train_mutex_;  // one training at a time per process: versions are assigned by probing
};

}  // namespace server
