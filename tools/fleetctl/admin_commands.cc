#include "admin_commands.h"

#include <cstdio>
#include <ctime>

namespace fleetctl {

AdminCommands::AdminCommands(CLI::App& app) {
  robots_ = app.add_subcommand("robots", "robots (admins)");
  robots_->require_subcommand(1);
  delete_ = robots_->add_subcommand(
      "delete", "delete a robot and everything it uploaded or that was derived from it (cannot be undone)");
  delete_->add_option("robot", robot_, "robot id")->required();
  delete_->add_option("--confirm", confirm_, "the robot id again")->required();
  audit_ = app.add_subcommand("audit", "the audit log, newest first (admins)");
  audit_->add_option("--limit", limit_, "at most this many entries")->check(CLI::Range(1, 1000));
  audit_->add_option("--before", before_, "entries older than this entry id");
}

std::optional<int> AdminCommands::Run(Client& client, const Global& global) const {
  if (*delete_) return Delete(client, global);
  if (*audit_) return Audit(client, global);
  return std::nullopt;
}

int AdminCommands::Delete(Client& client, const Global& global) const {
  fleet::v1::DeleteRobotRequest request;
  request.set_robot_id(robot_);
  request.set_confirm(confirm_);
  fleet::v1::DeleteRobotResponse response;
  auto context = client.Context(600);
  if (grpc::Status status = client.admin->DeleteRobot(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  std::printf(
      "robot %s deleted: %lld runs, %lld reports (%lld decisions, %lld ambiguous views, %lld regions), "
      "%lld map versions (%lld findings, %lld with metadata), %lld snapshots, %lld jobs, %lld credentials\n",
      response.robot_id().c_str(), static_cast<long long>(response.runs()),
      static_cast<long long>(response.reports()), static_cast<long long>(response.decisions()),
      static_cast<long long>(response.ambiguous_views()),
      static_cast<long long>(response.protrusion_regions()), static_cast<long long>(response.map_versions()),
      static_cast<long long>(response.map_findings()), static_cast<long long>(response.map_metadata()),
      static_cast<long long>(response.snapshots()), static_cast<long long>(response.jobs()),
      static_cast<long long>(response.credentials()));
  return 0;
}

int AdminCommands::Audit(Client& client, const Global& global) const {
  fleet::v1::ListAuditLogRequest request;
  request.set_limit(limit_);
  request.set_before_id(before_);
  fleet::v1::ListAuditLogResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.admin->ListAuditLog(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  std::printf("%6s %-20s %-20s %-18s %-24s %s\n", "entry", "when (UTC)", "actor", "action", "subject",
              "detail");
  for (const auto& entry : response.entries()) {
    const std::time_t seconds = static_cast<std::time_t>(entry.at());
    char when[32];
    std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", std::gmtime(&seconds));
    std::printf("%6lld %-20s %-20s %-18s %-24s %s\n", static_cast<long long>(entry.entry_id()), when,
                entry.actor().c_str(), entry.action().c_str(), entry.subject().c_str(),
                entry.detail_json().c_str());
  }
  return 0;
}

}  // namespace fleetctl
