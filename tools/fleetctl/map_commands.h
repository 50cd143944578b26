// fleetctl maps …: a robot's map history, its findings, repairs, reviews, the robot's hand-back and export.
//
//   maps robots [--pending] [--limit N] [--after ROBOT]   robots with their history in brief, a page at a time
//   maps list ROBOT                       versions with lineage, approval, figures, open findings
//   maps show ROBOT [VERSION]             one version (default: the current one) with its findings
//   maps repair ROBOT --base V (--reject-edge FROM:TO[:VIEW] | --reject-hypothesis H | --cut-finding F |
//                               --rollback | --undo) [--reason TEXT] [--approve]
//   maps approve ROBOT V | maps reject ROBOT V
//   maps get ROBOT [--held V] [--out FILE]   what the robot would download (MapSnapshot bytes to FILE)
//   maps export ROBOT [VERSION] --format map_server|g2o [--out DIR]
#pragma once

#include <CLI/CLI.hpp>

#include <cctype>
#include <memory>
#include <optional>
#include <string>

#include "client.h"

namespace fleetctl {

/// A wire state as the dashboard and the docs spell it: "MAP_ORIGIN_UPLOAD" → "upload"; "-" for UNSPECIFIED.
inline std::string Spelled(const std::string& enum_name, const std::string& prefix) {
  if (enum_name.rfind(prefix, 0) != 0 || enum_name == prefix + "UNSPECIFIED") return "-";
  std::string spelled = enum_name.substr(prefix.size());
  for (char& c : spelled) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return spelled;
}

class MapCommands {
 public:
  /// Adds "maps" and its subcommands to `app`.
  explicit MapCommands(CLI::App& app);
  /// Runs the parsed subcommand; nullopt when "maps" was not given.
  std::optional<int> Run(Client& client, const Global& global) const;

 private:
  int Robots(Client& client, const Global& global) const;
  int List(Client& client, const Global& global) const;
  int Show(Client& client, const Global& global) const;
  int Repair(Client& client, const Global& global) const;
  int Review(Client& client, const Global& global, bool approve) const;
  int Get(Client& client, const Global& global) const;
  int Export(Client& client, const Global& global) const;

  CLI::App* maps_ = nullptr;
  CLI::App *robots_ = nullptr, *list_ = nullptr, *show_ = nullptr, *repair_ = nullptr, *approve_ = nullptr,
           *reject_ = nullptr, *get_ = nullptr, *export_ = nullptr;
  std::string robot_, reject_edge_, reason_, format_, out_;
  std::int64_t version_ = 0, held_ = 0;
  std::int64_t reject_hypothesis_ = -1, cut_finding_ = 0;
  bool rollback_ = false, undo_ = false, approve_now_ = false, only_pending_ = false;
  int page_size_ = 0;  // 0: the server's default page
  std::string after_robot_;
};

}  // namespace fleetctl
