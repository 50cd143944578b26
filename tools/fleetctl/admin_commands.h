// fleetctl robots … and audit: erasure of a robot and the audit log (admins; docs/formats/service.md,
// "Erasure and retention").
//
//   robots delete ROBOT --confirm ROBOT   delete the robot and everything it uploaded or that was derived
//                                         from it; prints what was removed, table by table
//   audit [--limit N] [--before ID]       the audit log, newest first
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <optional>
#include <string>

#include "client.h"

namespace fleetctl {

class AdminCommands {
 public:
  /// Adds "robots" and "audit" to `app`.
  explicit AdminCommands(CLI::App& app);
  /// Runs the parsed subcommand; nullopt when neither was given.
  std::optional<int> Run(Client& client, const Global& global) const;

 private:
  int Delete(Client& client, const Global& global) const;
  int Audit(Client& client, const Global& global) const;

  CLI::App *robots_ = nullptr, *delete_ = nullptr, *audit_ = nullptr;
  std::string robot_, confirm_;
  int limit_ = 100;
  std::int64_t before_ = 0;
};

}  // namespace fleetctl
