#include "credential_commands.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <ctime>

namespace fleetctl {

CredentialCommands::CredentialCommands(CLI::App& app) {
  credentials_ = app.add_subcommand("credentials", "mint, rotate, revoke and list tokens");
  credentials_->add_option("principal", principal_,
                           "robot:<id>, engineer:<name> or admin:<name>: mint its token");
  credentials_->add_option("--out", out_, "write the token to this new file (mode 0600) instead of stdout");
  rotate_ =
      credentials_->add_subcommand("rotate", "a new secret for an existing token; the old one stops working");
  rotate_->add_option("principal", principal_, "whose token")->required();
  rotate_->add_option("--out", out_, "write the token to this new file (mode 0600) instead of stdout");
  revoke_ = credentials_->add_subcommand("revoke", "refuse a principal's token from now on");
  revoke_->add_option("principal", principal_, "whose token")->required();
  list_ = credentials_->add_subcommand("list", "principals with a credential (never a secret)");
  list_->add_option("--prefix", prefix_, "e.g. robot:");
  list_->add_flag("--revoked", include_revoked_, "also revoked ones");
}

int CredentialCommands::PrintToken(const fleet::v1::SetCredentialResponse& response,
                                   const Global& global) const {
  if (!out_.empty()) {
    const int fd = ::open(out_.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0600);
    if (fd < 0) {
      std::perror(("fleetctl: " + out_).c_str());
      return 1;
    }
    const std::string line = response.token() + "\n";
    const bool written = ::write(fd, line.data(), line.size()) == static_cast<ssize_t>(line.size());
    ::close(fd);
    if (!written) {
      std::fprintf(stderr, "fleetctl: %s: write failed\n", out_.c_str());
      return 1;
    }
    std::printf("token of %s written to %s\n", response.principal().c_str(), out_.c_str());
    return 0;
  }
  if (global.json) {
    PrintJson(response);
  } else {
    std::printf("%s\n", response.token().c_str());
  }
  return 0;
}

int CredentialCommands::List(Client& client, const Global& global) const {
  fleet::v1::ListCredentialsResponse all;
  std::string page_token;
  do {
    fleet::v1::ListCredentialsRequest request;
    request.set_prefix(prefix_);
    request.set_page_size(1000);
    request.set_page_token(page_token);
    request.set_include_revoked(include_revoked_);
    fleet::v1::ListCredentialsResponse page;
    auto context = client.Context();
    if (grpc::Status status = client.admin->ListCredentials(context.get(), request, &page); !status.ok()) {
      return Fail(status);
    }
    all.mutable_credentials()->MergeFrom(page.credentials());
    page_token = page.next_page_token();
  } while (!page_token.empty());
  if (global.json) {
    PrintJson(all);
    return 0;
  }
  std::printf("%-40s %-9s %-8s %s\n", "principal", "role", "state", "updated (UTC)");
  for (const fleet::v1::Credential& credential : all.credentials()) {
    const std::time_t at = static_cast<std::time_t>(credential.updated_at());
    std::tm tm{};
    gmtime_r(&at, &tm);
    char when[32];
    std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", &tm);
    std::printf("%-40s %-9s %-8s %s\n", credential.principal().c_str(), credential.role().c_str(),
                credential.revoked() ? "revoked" : "active", when);
  }
  return 0;
}

std::optional<int> CredentialCommands::Run(Client& client, const Global& global) const {
  if (!*credentials_) return std::nullopt;
  if (*list_) return List(client, global);
  if (*revoke_) {
    fleet::v1::RevokeCredentialRequest request;
    request.set_principal(principal_);
    fleet::v1::RevokeCredentialResponse response;
    auto context = client.Context();
    if (grpc::Status status = client.admin->RevokeCredential(context.get(), request, &response);
        !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
    } else {
      std::printf("revoked %s\n", response.principal().c_str());
    }
    return 0;
  }
  if (principal_.empty()) {
    std::fprintf(stderr, "fleetctl: credentials: name a principal, or rotate|revoke|list\n");
    return 2;
  }
  fleet::v1::SetCredentialResponse response;
  auto context = client.Context();
  grpc::Status status;
  if (*rotate_) {
    fleet::v1::RotateCredentialRequest request;
    request.set_principal(principal_);
    status = client.admin->RotateCredential(context.get(), request, &response);
  } else {
    fleet::v1::SetCredentialRequest request;
    request.set_principal(principal_);
    status = client.admin->SetCredential(context.get(), request, &response);
  }
  if (!status.ok()) return Fail(status);
  return PrintToken(response, global);
}

}  // namespace fleetctl
