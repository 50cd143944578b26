// fleetctl credentials …: tokens of robots, engineers and admins.
//
//   credentials PRINCIPAL                 mint a token (admins; replaces the principal's previous one)
//   credentials rotate PRINCIPAL          a new secret for an existing token; the old one is refused from then
//                                         on (admins for anyone, everyone for itself)
//   credentials revoke PRINCIPAL          the token is refused at once by every fleetd (admins)
//   credentials list [--prefix P] [--revoked]   principals with a credential (admins; never a secret)
// A minted or rotated token goes to stdout, or with --out FILE into a new file readable by its owner only
// (so it never has to pass through a command line).
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <string>

#include "client.h"

namespace fleetctl {

class CredentialCommands {
 public:
  /// Adds "credentials" and its subcommands to `app`.
  explicit CredentialCommands(CLI::App& app);
  /// Runs the parsed command; nullopt when "credentials" was not given.
  std::optional<int> Run(Client& client, const Global& global) const;

 private:
  int PrintToken(const fleet::v1::SetCredentialResponse& response, const Global& global) const;
  int List(Client& client, const Global& global) const;

  CLI::App *credentials_ = nullptr, *rotate_ = nullptr, *revoke_ = nullptr, *list_ = nullptr;
  std::string principal_, prefix_, out_;
  bool include_revoked_ = false;
};

}  // namespace fleetctl
