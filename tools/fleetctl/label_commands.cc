#include "label_commands.h"

#include <cstdio>

namespace fleetctl {

LabelCommands::LabelCommands(CLI::App& app) {
  regions_ = app.add_subcommand("regions", "protrusion regions of a run");
  regions_->add_option("run", run_id_, "run id")->required();
  regions_->add_option("--robot", run_robot_, "the run's robot (needed when robots share the run id)");
  regions_->add_option("--parameter-set", parameter_set_, "parameter set");
  label_ = app.add_subcommand("label", "label a protrusion region");
  label_->add_option("run", run_id_, "run id")->required();
  label_->add_option("--robot", run_robot_, "the run's robot (needed when robots share the run id)");
  label_->add_option("region", region_id_, "region id")->required();
  label_->add_option("label", label_value_, "protrusion or new_space")->required();
  label_->add_option("--parameter-set", parameter_set_, "parameter set");

  label_from_truth_ = app.add_subcommand(
      "label-from-truth",
      "label every region whose run carries simulator ground truth (fleetsim) with that truth");
  label_from_truth_->add_option("--parameter-set", parameter_set_, "parameter set");

  auto* models = app.add_subcommand("models", "protrusion classifier models");
  models->require_subcommand(1);
  train_ = models->add_subcommand("train", "train from labelled regions");
  train_->add_option("name", model_name_, "model name, e.g. protrusion")->required();
  train_->add_option("--classifier", classifier_, "decision_tree, random_forest, svm");
  train_->add_option("--parameter-set", parameter_set_, "labelled regions of this set only");
  eval_ = models->add_subcommand("eval", "evaluate on labelled regions");
  eval_->add_option("name", model_name_, "model name")->required();
  eval_->add_option("--version", version_, "version (default: active)");
  eval_->add_option("--parameter-set", parameter_set_, "labelled regions of this set only");
  activate_ = models->add_subcommand("activate", "make a version active");
  activate_->add_option("name", model_name_, "model name")->required();
  activate_->add_option("version", version_, "version")->required();
  models_list_ = models->add_subcommand("list", "versions of a model");
  models_list_->add_option("name", model_name_, "model name")->required();
}

std::optional<int> LabelCommands::Run(Client& client, const Global& global) const {
  if (regions_->parsed()) return Regions(client, global);
  if (label_->parsed()) return Label(client, global);
  if (label_from_truth_->parsed()) return LabelFromTruth(client, global);
  if (train_->parsed()) return Train(client, global);
  if (eval_->parsed()) return Evaluate(client, global);
  if (activate_->parsed()) return Activate(client, global);
  if (models_list_->parsed()) return ListModels(client, global);
  return std::nullopt;
}

int LabelCommands::Regions(Client& client, const Global& global) const {
  fleet::v1::ListRegionsRequest request;
  request.set_run_id(run_id_);
  request.set_robot_id(run_robot_);
  request.set_parameter_set(parameter_set_);
  fleet::v1::ListRegionsResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.labels->ListRegions(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  std::printf("%6s %-12s %-10s %6s %-12s %-10s %s\n", "region", "predicted", "decided by", "p", "label", "by",
              "bbox (cells)");
  for (const auto& r : response.regions()) {
    std::printf("%6lld %-12s %-10s %6.2f %-12s %-10s [%g %g %g %g]\n", static_cast<long long>(r.region_id()),
                r.predicted_class().c_str(), r.decided_by().c_str(), r.probability(), r.label().c_str(),
                r.labelled_by().c_str(), r.bbox(0), r.bbox(1), r.bbox(2), r.bbox(3));
  }
  return 0;
}

int LabelCommands::Label(Client& client, const Global& global) const {
  fleet::v1::LabelRegionRequest request;
  request.set_run_id(run_id_);
  request.set_robot_id(run_robot_);
  request.set_parameter_set(parameter_set_);
  request.set_region_id(region_id_);
  request.set_label(label_value_);
  fleet::v1::LabelRegionResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.labels->LabelRegion(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
  } else {
    std::cout << "region " << region_id_ << " of " << run_id_ << " labelled " << label_value_ << "\n";
  }
  return 0;
}

int LabelCommands::LabelFromTruth(Client& client, const Global& global) const {
  // Runs page by page; each report says which regions are slip artefacts by the simulator's truth.
  int labelled = 0, runs_seen = 0;
  std::string token;
  do {
    fleet::v1::ListRunsRequest list;
    list.set_page_size(500);
    list.set_page_token(token);
    fleet::v1::ListRunsResponse page;
    if (grpc::Status status = client.CallRetrying(
            [&](grpc::ClientContext* context) { return client.queries->ListRuns(context, list, &page); });
        !status.ok()) {
      return Fail(status);
    }
    for (const auto& run : page.runs()) {
      ++runs_seen;
      fleet::v1::GetRunReportRequest request;
      request.set_run_id(run.run_id());
      request.set_robot_id(run.robot_id());
      request.set_parameter_set(parameter_set_);
      fleet::v1::GetRunReportResponse response;
      if (grpc::Status status = client.CallRetrying([&](grpc::ClientContext* context) {
            return client.queries->GetRunReport(context, request, &response);
          });
          !status.ok()) {
        if (status.error_code() == grpc::StatusCode::NOT_FOUND) continue;  // not analysed yet
        return Fail(status);
      }
      for (const auto& region : response.report().protrusion_regions()) {
        if (!region.has_truth_protrusion()) continue;
        fleet::v1::LabelRegionRequest label_request;
        label_request.set_run_id(run.run_id());
        label_request.set_robot_id(run.robot_id());
        label_request.set_parameter_set(parameter_set_);
        label_request.set_region_id(region.id());
        label_request.set_label(region.truth_protrusion() ? "protrusion" : "new_space");
        fleet::v1::LabelRegionResponse label_response;
        if (grpc::Status status = client.CallRetrying([&](grpc::ClientContext* context) {
              return client.labels->LabelRegion(context, label_request, &label_response);
            });
            !status.ok()) {
          return Fail(status);
        }
        ++labelled;
      }
    }
    token = page.next_page_token();
  } while (!token.empty());
  if (global.json) {
    std::cout << "{\"regions_labelled\": " << labelled << ", \"runs\": " << runs_seen << "}\n";
  } else {
    std::cout << labelled << " regions of " << runs_seen << " runs labelled from ground truth\n";
  }
  return 0;
}

int LabelCommands::Train(Client& client, const Global& global) const {
  fleet::v1::TrainModelRequest request;
  request.set_name(model_name_);
  request.set_classifier(classifier_);
  request.set_parameter_set(parameter_set_);
  fleet::v1::TrainModelResponse response;
  auto context = client.Context(3600);
  if (grpc::Status status = client.models->TrainModel(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
  } else {
    const auto& cv = response.cross_validation();
    std::printf("model %s version %lld (%s) from %lld regions; ", model_name_.c_str(),
                static_cast<long long>(response.model().version()), response.model().classifier().c_str(),
                static_cast<long long>(response.training_regions()));
    if (cv.folds() >= 2) {
      std::printf("%d-fold CV precision %.3f recall %.3f FPR %.3f\n", cv.folds(), cv.precision(), cv.recall(),
                  cv.false_positive_rate());
    } else {
      std::printf("not cross-validated (too few labelled runs of each class to hold out)\n");
    }
  }
  return 0;
}

int LabelCommands::Evaluate(Client& client, const Global& global) const {
  fleet::v1::EvaluateModelRequest request;
  request.set_name(model_name_);
  request.set_version(version_);
  request.set_parameter_set(parameter_set_);
  fleet::v1::EvaluateModelResponse response;
  auto context = client.Context(600);
  if (grpc::Status status = client.models->EvaluateModel(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
  } else {
    const auto& e = response.evaluation();
    std::printf("model %s v%lld on %lld regions: precision %.3f recall %.3f FPR %.3f accuracy %.3f\n",
                model_name_.c_str(), static_cast<long long>(response.model().version()),
                static_cast<long long>(response.regions()), e.precision(), e.recall(),
                e.false_positive_rate(), e.accuracy());
  }
  return 0;
}

int LabelCommands::Activate(Client& client, const Global& global) const {
  fleet::v1::ActivateModelRequest request;
  request.set_name(model_name_);
  request.set_version(version_);
  fleet::v1::Model response;
  auto context = client.Context();
  if (grpc::Status status = client.models->ActivateModel(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
  } else {
    std::cout << "model " << model_name_ << " version " << version_ << " is active\n";
  }
  return 0;
}

int LabelCommands::ListModels(Client& client, const Global& global) const {
  fleet::v1::ListModelsRequest request;
  request.set_name(model_name_);
  fleet::v1::ListModelsResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.models->ListModels(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  for (const auto& m : response.models()) {
    std::printf("%s v%lld %-14s threshold %.2f%s\n", m.name().c_str(), static_cast<long long>(m.version()),
                m.classifier().c_str(), m.threshold(), m.active() ? "  (active)" : "");
  }
  return 0;
}

}  // namespace fleetctl
