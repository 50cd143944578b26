// fleetctl's read commands: runs, one run's report, fleet statistics, and the comparison of two parameter sets.
//
//   runs [filters] [--limit N]                          runs, newest pages followed up to N
//   report RUN [--robot R] [--parameter-set S] [--with-map]
//   stats [filters] [--group-by day|firmware|robot_model|parameter_set|robot]
//   compare A B [filters] [--top N]                     fleet-wide and run by run
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <string>

#include "client.h"

namespace fleetctl {

class QueryCommands {
 public:
  /// Adds the commands above to `app`.
  explicit QueryCommands(CLI::App& app);
  /// Runs the parsed command; nullopt when none of these was given.
  std::optional<int> Run(Client& client, const Global& global) const;

 private:
  int Runs(Client& client, const Global& global) const;
  int Report(Client& client, const Global& global) const;
  int Stats(Client& client, const Global& global) const;
  int Compare(Client& client, const Global& global) const;

  CLI::App *runs_ = nullptr, *report_ = nullptr, *stats_ = nullptr, *compare_ = nullptr;
  Filter filter_;
  int limit_ = 100, top_ = 10;
  std::string run_id_, run_robot_, parameter_set_, group_by_ = "none", set_a_, set_b_;
  bool with_map_ = false;
};

}  // namespace fleetctl
