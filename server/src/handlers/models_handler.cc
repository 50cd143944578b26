#include "models_handler.h"

#include <nlohmann/json.hpp>
#include <set>

#include "server/analysis.h"
#include "server/log.h"
#include "slamcore/protrusion_classifier.h"
#include "slamcore/protrusion_detector.h"

namespace server {
namespace {

bool ValidName(const std::string& name) {
  return !name.empty() && name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
}

/// Labelled regions as training rows (features in ProtrusionFeatureNames() order; group = run).
storage::Result<std::vector<slamcore::LabelledRegion>> LabelledData(storage::Repository& repository,
                                                                    const std::string& parameter_set) {
  ASSIGN_OR_RETURN(auto regions, repository.ListLabelledRegions(parameter_set, 1000000));
  const auto& names = slamcore::ProtrusionFeatureNames();
  std::vector<slamcore::LabelledRegion> data;
  for (const auto& region : regions) {
    if (!region.label || (*region.label != "protrusion" && *region.label != "new_space")) continue;
    nlohmann::json features;
    try {
      features = nlohmann::json::parse(region.features_json);
    } catch (const std::exception&) {
      continue;
    }
    slamcore::LabelledRegion row;
    row.group = region.run_id;
    row.label = *region.label == "protrusion" ? 1 : 0;
    bool complete = true;
    for (const auto& name : names) {
      if (!features.contains(name) || !features[name].is_number()) {
        complete = false;
        break;
      }
      row.features.push_back(features[name].get<double>());
    }
    if (complete) data.push_back(std::move(row));
  }
  return data;
}

void Fill(const slamcore::ConfusionMatrix& confusion, int folds, fleet::v1::Evaluation* out) {
  out->set_true_positives(confusion.true_positives);
  out->set_false_positives(confusion.false_positives);
  out->set_true_negatives(confusion.true_negatives);
  out->set_false_negatives(confusion.false_negatives);
  out->set_precision(confusion.Precision());
  out->set_recall(confusion.Recall());
  out->set_false_positive_rate(confusion.FalsePositiveRate());
  out->set_accuracy(confusion.Accuracy());
  out->set_folds(folds);
}

void Describe(const slamcore::ProtrusionClassifier& classifier, const storage::ModelRecord& record,
              bool active, fleet::v1::Model* out) {
  out->set_name(record.name);
  out->set_version(record.version);
  out->set_active(active);
  out->set_classifier(slamcore::ClassifierKindName(classifier.kind()));
  const auto& names = slamcore::ProtrusionFeatureNames();
  for (int index : classifier.selected_features()) {
    if (index >= 0 && static_cast<std::size_t>(index) < names.size()) {
      out->add_selected_features(names[static_cast<std::size_t>(index)]);
    }
  }
  out->set_threshold(classifier.threshold());
}

grpc::Status ModelNotFound(const std::string& name, std::int64_t version) {
  return {grpc::StatusCode::NOT_FOUND,
          version == 0 ? "name: model \"" + name + "\" has no active version"
                       : "version: model \"" + name + "\" has no version " + std::to_string(version)};
}

}  // namespace

grpc::Status ModelsHandler::TrainModel(grpc::ServerContext* call, const fleet::v1::TrainModelRequest* request,
                                       fleet::v1::TrainModelResponse* response) {
  RpcScope scope(context_.metrics, "Models/TrainModel");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kModels, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  grpc::Status status = DoTrain(request, response);
  if (status.ok()) {
    log::Info("model_trained", {{"name", request->name()},
                                {"version", static_cast<long long>(response->model().version())},
                                {"regions", static_cast<long long>(response->training_regions())},
                                {"principal", principal.name}});
  }
  return scope.Done(status);
}

grpc::Status ModelsHandler::DoTrain(const fleet::v1::TrainModelRequest* request,
                                    fleet::v1::TrainModelResponse* response) {
  if (!ValidName(request->name())) return InvalidArgument("name: 1-64 characters of [A-Za-z0-9_.-] required");
  slamcore::ClassifierOptions options;
  if (!request->classifier().empty()) {
    auto kind = slamcore::ParseClassifierKind(request->classifier());
    if (!kind.ok()) {
      return InvalidArgument("classifier: unknown \"" + request->classifier() +
                             "\" (decision_tree, random_forest, svm)");
    }
    options.kind = *kind;
  }
  const auto& names = slamcore::ProtrusionFeatureNames();
  for (int i = 0; i < request->selected_features_size(); ++i) {
    auto it = std::find(names.begin(), names.end(), request->selected_features(i));
    if (it == names.end()) {
      return InvalidArgument("selected_features[" + std::to_string(i) + "]: unknown feature \"" +
                             request->selected_features(i) + "\"");
    }
    options.selected_features.push_back(static_cast<int>(it - names.begin()));
  }
  if (request->threshold() < 0 || request->threshold() >= 1)
    return InvalidArgument("threshold: expected [0, 1)");
  if (request->threshold() > 0) options.threshold = request->threshold();
  if (request->folds() < 0 || request->folds() == 1 || request->folds() > 20) {
    return InvalidArgument("folds: expected 0 (default 5) or 2..20");
  }
  auto data = LabelledData(*context_.repository, request->parameter_set());
  if (!data.ok()) return ToGrpc(data.status());
  long positives = 0;
  std::set<std::string> groups;
  for (const auto& row : *data) {
    positives += row.label;
    groups.insert(row.group);
  }
  const long negatives = static_cast<long>(data->size()) - positives;
  if (positives == 0 || negatives == 0) {
    return {grpc::StatusCode::FAILED_PRECONDITION, "labelled regions: training needs both classes; have " +
                                                       std::to_string(positives) + " protrusion and " +
                                                       std::to_string(negatives) +
                                                       " new_space (label more with Labels.LabelRegion)"};
  }
  const int folds =
      std::min<int>(request->folds() == 0 ? 5 : request->folds(), static_cast<int>(groups.size()));
  if (folds >= 2) {
    auto validated = slamcore::CrossValidate(*data, options, folds);
    if (validated.ok()) Fill(validated->confusion, validated->folds, response->mutable_cross_validation());
  }
  auto trained = slamcore::ProtrusionClassifier::Train(*data, options);
  if (!trained.ok()) return ToGrpc(trained.status());

  auto bytes = (*trained)->ToBytes();
  if (!bytes.ok()) return ToGrpc(bytes.status());

  std::lock_guard lock(train_mutex_);
  storage::ModelRecord record;
  record.name = request->name();
  record.bytes = std::move(bytes).value();
  for (record.version = 1; record.version < 100000; ++record.version) {
    auto existing = context_.repository->GetModel(record.name, record.version);
    if (!existing.ok() && existing.status().code() == storage::StatusCode::kNotFound) break;
    if (!existing.ok()) return ToGrpc(existing.status());
  }
  auto stored = context_.repository->PutModel(record);
  if (!stored.ok()) return ToGrpc(stored.status());
  Describe(**trained, record, false, response->mutable_model());
  response->set_training_regions(static_cast<std::int64_t>(data->size()));
  return grpc::Status::OK;
}

grpc::Status ModelsHandler::EvaluateModel(grpc::ServerContext* call,
                                          const fleet::v1::EvaluateModelRequest* request,
                                          fleet::v1::EvaluateModelResponse* response) {
  RpcScope scope(context_.metrics, "Models/EvaluateModel");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  return scope.Done(DoEvaluate(request, response));
}

grpc::Status ModelsHandler::DoEvaluate(const fleet::v1::EvaluateModelRequest* request,
                                       fleet::v1::EvaluateModelResponse* response) {
  if (!ValidName(request->name())) return InvalidArgument("name: 1-64 characters of [A-Za-z0-9_.-] required");
  if (request->version() < 0) return InvalidArgument("version: must be >= 0 (0: the active version)");
  auto record = request->version() == 0 ? context_.repository->GetActiveModel(request->name())
                                        : context_.repository->GetModel(request->name(), request->version());
  if (!record.ok()) {
    if (record.status().code() == storage::StatusCode::kNotFound)
      return ModelNotFound(request->name(), request->version());
    return ToGrpc(record.status());
  }
  auto classifier = LoadClassifier(record->bytes);
  if (!classifier.ok()) return ToGrpc(classifier.status());
  auto data = LabelledData(*context_.repository, request->parameter_set());
  if (!data.ok()) return ToGrpc(data.status());
  slamcore::ConfusionMatrix confusion;
  for (const auto& row : *data) {
    auto probability = (*classifier)->Probability(row.features);
    if (!probability.ok()) return ToGrpc(probability.status());
    confusion.Add(row.label == 1, (*classifier)->IsProtrusion(*probability));
  }
  auto active = context_.repository->GetActiveModel(request->name());
  Describe(**classifier, *record, active.ok() && active->version == record->version,
           response->mutable_model());
  Fill(confusion, 0, response->mutable_evaluation());
  response->set_regions(static_cast<std::int64_t>(data->size()));
  return grpc::Status::OK;
}

grpc::Status ModelsHandler::ActivateModel(grpc::ServerContext* call,
                                          const fleet::v1::ActivateModelRequest* request,
                                          fleet::v1::Model* response) {
  RpcScope scope(context_.metrics, "Models/ActivateModel");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kModels, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (!ValidName(request->name()))
    return scope.Done(InvalidArgument("name: 1-64 characters of [A-Za-z0-9_.-] required"));
  if (request->version() <= 0) return scope.Done(InvalidArgument("version: must be positive"));
  auto record = context_.repository->GetModel(request->name(), request->version());
  if (!record.ok()) {
    if (record.status().code() == storage::StatusCode::kNotFound) {
      return scope.Done(ModelNotFound(request->name(), request->version()));
    }
    return scope.Done(ToGrpc(record.status()));
  }
  auto classifier = LoadClassifier(record->bytes);
  if (!classifier.ok()) return scope.Done(ToGrpc(classifier.status()));
  if (storage::Status activated = context_.repository->ActivateModel(request->name(), request->version());
      !activated.ok()) {
    return scope.Done(ToGrpc(activated));
  }
  Describe(**classifier, *record, true, response);
  log::Info("model_activated", {{"name", request->name()},
                                {"version", static_cast<long long>(request->version())},
                                {"principal", principal.name}});
  return scope.Done(grpc::Status::OK);
}

grpc::Status ModelsHandler::ListModels(grpc::ServerContext* call, const fleet::v1::ListModelsRequest* request,
                                       fleet::v1::ListModelsResponse* response) {
  RpcScope scope(context_.metrics, "Models/ListModels");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (!ValidName(request->name())) {
    return scope.Done(InvalidArgument("name: required (storage lists models by name), e.g. \"protrusion\""));
  }
  auto active = context_.repository->GetActiveModel(request->name());
  for (std::int64_t version = 1; version < 100000; ++version) {
    auto record = context_.repository->GetModel(request->name(), version);
    if (!record.ok()) {
      if (record.status().code() == storage::StatusCode::kNotFound) break;
      return scope.Done(ToGrpc(record.status()));
    }
    auto classifier = LoadClassifier(record->bytes);
    fleet::v1::Model* model = response->add_models();
    if (classifier.ok()) {
      Describe(**classifier, *record, active.ok() && active->version == version, model);
    } else {
      model->set_name(record->name);
      model->set_version(version);
      model->set_active(active.ok() && active->version == version);
    }
  }
  return scope.Done(grpc::Status::OK);
}

}  // namespace server
