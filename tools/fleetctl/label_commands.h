// fleetctl's labelling and classifier commands.
//
//   regions RUN [--robot R] [--parameter-set S]            protrusion regions of a run
//   label RUN REGION protrusion|new_space [--robot R] [--parameter-set S]
//   label-from-truth [--parameter-set S]                   label from the simulator's ground truth
//   models train NAME [--classifier K] | models eval NAME [--version V] | models activate NAME V | models list NAME
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <string>

#include "client.h"

namespace fleetctl {

class LabelCommands {
 public:
  explicit LabelCommands(CLI::App& app);
  std::optional<int> Run(Client& client, const Global& global) const;

 private:
  int Regions(Client& client, const Global& global) const;
  int Label(Client& client, const Global& global) const;
  int LabelFromTruth(Client& client, const Global& global) const;
  int Train(Client& client, const Global& global) const;
  int Evaluate(Client& client, const Global& global) const;
  int Activate(Client& client, const Global& global) const;
  int ListModels(Client& client, const Global& global) const;

  CLI::App *regions_ = nullptr, *label_ = nullptr, *label_from_truth_ = nullptr, *train_ = nullptr,
           *eval_ = nullptr, *activate_ = nullptr, *models_list_ = nullptr;
  std::string run_id_, run_robot_, parameter_set_, label_value_, model_name_, classifier_;
  std::int64_t region_id_ = 0, version_ = 0;
};

}  // namespace fleetctl
