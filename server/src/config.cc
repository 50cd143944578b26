#include "server/config.h"

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "server/secrets.h"
#include "storage/repository.h"

namespace server {

slamcore::Status FleetdConfig::Validate() const {
  if (db.empty()) return slamcore::InvalidArgument("db: required");
  if (role != "all" && role != "server" && role != "worker") {
    return slamcore::InvalidArgument("role: expected all, server or worker, got \"" + role + "\"");
  }
  if (role != "worker" && listen.empty()) return slamcore::InvalidArgument("listen: required");
  if (workers < 0 || workers > 256) return slamcore::InvalidArgument("workers: expected 0..256");
  if (tls_cert.empty() != tls_key.empty())
    return slamcore::InvalidArgument("tls_cert, tls_key: set both or neither");
  if (max_message_bytes < 1024 || max_message_bytes > (1LL << 30)) {
    return slamcore::InvalidArgument("max_message_bytes: expected 1 KiB..1 GiB");
  }
  if (max_events_per_run < 1) return slamcore::InvalidArgument("max_events_per_run: must be positive");
  if (max_run_bytes < max_message_bytes)
    return slamcore::InvalidArgument("max_run_bytes: below max_message_bytes");
  if (max_upload_streams < 1 || max_upload_streams_per_principal < 1 ||
      max_upload_streams_per_principal > max_upload_streams) {
    return slamcore::InvalidArgument(
        "max_upload_streams, max_upload_streams_per_principal: expected 1 <= per principal <= in all");
  }
  // One run within max_run_bytes must fit when it is alone, so that RESOURCE_EXHAUSTED always means "later".
  if (max_upload_bytes_per_principal < max_run_bytes ||
      max_upload_bytes_in_flight < max_upload_bytes_per_principal) {
    return slamcore::InvalidArgument(
        "max_upload_bytes_per_principal, max_upload_bytes_in_flight: expected max_run_bytes <= per principal "
        "<= in all");
  }
  if (!(health_probe_seconds >= 0.1 && health_probe_seconds <= 3600)) {
    return slamcore::InvalidArgument("health_probe_seconds: expected 0.1..3600");
  }
  if (!bootstrap_admin_token.empty()) {
    const std::size_t dot = bootstrap_admin_token.rfind('.');
    RETURN_IF_ERROR(CheckSecretStrength(
        "bootstrap_admin_token", dot == std::string::npos ? "" : bootstrap_admin_token.substr(dot + 1), 32));
  }
  for (const std::string& password : storage::DatabaseUrlPasswords(db)) {
    RETURN_IF_ERROR(CheckSecretStrength("db: the URL's password", password, 16));
  }
  if (rate_limit_per_second < 0 || rate_limit_burst < 1) {
    return slamcore::InvalidArgument("rate_limit_per_second, rate_limit_burst: expected >= 0 and >= 1");
  }
  if (shutdown_grace_seconds < 0) return slamcore::InvalidArgument("shutdown_grace_seconds: must be >= 0");
  if (default_parameter_set.empty()) return slamcore::InvalidArgument("default_parameter_set: required");
  if (lease_seconds < 4) return slamcore::InvalidArgument("lease_seconds: at least 4");
  if (!std::isfinite(analysis_budget_seconds))
    return slamcore::InvalidArgument("analysis_budget_seconds: must be finite");
  if (auth_cache_seconds < 0) return slamcore::InvalidArgument("auth_cache_seconds: must be >= 0");
  for (const auto& [name, days] :
       {std::pair{"retain_runs_days", retain_runs_days}, {"retain_jobs_days", retain_jobs_days}}) {
    if (!std::isfinite(days) || days < 0 || days > 36500) {
      return slamcore::InvalidArgument(std::string(name) + ": expected 0 (keep for ever) .. 36500 days");
    }
  }
  if (!std::isfinite(retention_interval_seconds) || retention_interval_seconds < 1 ||
      retention_interval_seconds > 86400 * 7) {
    return slamcore::InvalidArgument("retention_interval_seconds: expected 1 .. 604800");
  }
  if (log_format != "json" && log_format != "text")
    return slamcore::InvalidArgument("log_format: json or text");
  if (auto_repair != "none" && auto_repair != "cut_protrusions" && auto_repair != "repair_findings") {
    return slamcore::InvalidArgument(
        "auto_repair: expected none, cut_protrusions or repair_findings, got \"" + auto_repair + "\"");
  }
  if (auto_repair_protrusions != "any" && auto_repair_protrusions != "views") {
    return slamcore::InvalidArgument("auto_repair_protrusions: expected any or views, got \"" +
                                     auto_repair_protrusions + "\"");
  }
  if (!(auto_repair_min_severity >= 0.0 && auto_repair_min_severity <= 1.0)) {
    return slamcore::InvalidArgument("auto_repair_min_severity: expected 0 .. 1");
  }
  if (log_level != "debug" && log_level != "info" && log_level != "warn" && log_level != "error") {
    return slamcore::InvalidArgument("log_level: debug, info, warn or error");
  }
  return slamcore::Status::Ok();
}

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> items;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    std::string item = text.substr(start, end - start);
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (!item.empty()) items.push_back(item);
    start = end + 1;
  }
  return items;
}

slamcore::Status LoadConfigFile(const std::string& path, FleetdConfig& config) {
  std::ifstream in(path);
  if (!in) return slamcore::NotFound("config: cannot read " + path);
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    return slamcore::InvalidArgument("config " + path + ": " + e.what());
  }
  if (!json.is_object()) return slamcore::InvalidArgument("config " + path + ": expected a JSON object");
  using Setter = std::function<void(const nlohmann::json&)>;
  const std::map<std::string, Setter> setters = {
      {"db", [&](const nlohmann::json& v) { config.db = v.get<std::string>(); }},
      {"listen", [&](const nlohmann::json& v) { config.listen = v.get<std::string>(); }},
      {"http", [&](const nlohmann::json& v) { config.http = v.get<std::string>(); }},
      {"http_allowed_hosts",
       [&](const nlohmann::json& v) { config.http_allowed_hosts = v.get<std::string>(); }},
      {"metrics_open", [&](const nlohmann::json& v) { config.metrics_open = v.get<bool>(); }},
      {"lifelong_results", [&](const nlohmann::json& v) { config.lifelong_results = v.get<std::string>(); }},
      {"role", [&](const nlohmann::json& v) { config.role = v.get<std::string>(); }},
      {"workers", [&](const nlohmann::json& v) { config.workers = v.get<int>(); }},
      {"tls_cert", [&](const nlohmann::json& v) { config.tls_cert = v.get<std::string>(); }},
      {"tls_key", [&](const nlohmann::json& v) { config.tls_key = v.get<std::string>(); }},
      {"bootstrap_admin_token",
       [&](const nlohmann::json& v) { config.bootstrap_admin_token = v.get<std::string>(); }},
      {"bootstrap_admin_force",
       [&](const nlohmann::json& v) { config.bootstrap_admin_force = v.get<bool>(); }},
      {"max_upload_streams", [&](const nlohmann::json& v) { config.max_upload_streams = v.get<int>(); }},
      {"max_upload_streams_per_principal",
       [&](const nlohmann::json& v) { config.max_upload_streams_per_principal = v.get<int>(); }},
      {"max_upload_bytes_in_flight",
       [&](const nlohmann::json& v) { config.max_upload_bytes_in_flight = v.get<std::int64_t>(); }},
      {"max_upload_bytes_per_principal",
       [&](const nlohmann::json& v) { config.max_upload_bytes_per_principal = v.get<std::int64_t>(); }},
      {"health_probe_seconds",
       [&](const nlohmann::json& v) { config.health_probe_seconds = v.get<double>(); }},
      {"max_message_bytes",
       [&](const nlohmann::json& v) { config.max_message_bytes = v.get<std::int64_t>(); }},
      {"max_events_per_run",
       [&](const nlohmann::json& v) { config.max_events_per_run = v.get<std::int64_t>(); }},
      {"max_run_bytes", [&](const nlohmann::json& v) { config.max_run_bytes = v.get<std::int64_t>(); }},
      {"rate_limit_per_second",
       [&](const nlohmann::json& v) { config.rate_limit_per_second = v.get<double>(); }},
      {"rate_limit_burst", [&](const nlohmann::json& v) { config.rate_limit_burst = v.get<double>(); }},
      {"shutdown_grace_seconds",
       [&](const nlohmann::json& v) { config.shutdown_grace_seconds = v.get<double>(); }},
      {"default_parameter_set",
       [&](const nlohmann::json& v) { config.default_parameter_set = v.get<std::string>(); }},
      {"model_name", [&](const nlohmann::json& v) { config.model_name = v.get<std::string>(); }},
      {"analysis_budget_seconds",
       [&](const nlohmann::json& v) { config.analysis_budget_seconds = v.get<double>(); }},
      {"lease_seconds", [&](const nlohmann::json& v) { config.lease_seconds = v.get<int>(); }},
      {"auth_cache_seconds", [&](const nlohmann::json& v) { config.auth_cache_seconds = v.get<int>(); }},
      {"log_level", [&](const nlohmann::json& v) { config.log_level = v.get<std::string>(); }},
      {"log_format", [&](const nlohmann::json& v) { config.log_format = v.get<std::string>(); }},
      {"auto_repair", [&](const nlohmann::json& v) { config.auto_repair = v.get<std::string>(); }},
      {"auto_approve", [&](const nlohmann::json& v) { config.auto_approve = v.get<bool>(); }},
      {"auto_repair_protrusions",
       [&](const nlohmann::json& v) { config.auto_repair_protrusions = v.get<std::string>(); }},
      {"auto_repair_min_severity",
       [&](const nlohmann::json& v) { config.auto_repair_min_severity = v.get<double>(); }},
      {"retain_runs_days", [&](const nlohmann::json& v) { config.retain_runs_days = v.get<double>(); }},
      {"retain_jobs_days", [&](const nlohmann::json& v) { config.retain_jobs_days = v.get<double>(); }},
      {"retention_interval_seconds",
       [&](const nlohmann::json& v) { config.retention_interval_seconds = v.get<double>(); }},
  };
  for (const auto& [key, value] : json.items()) {
    auto setter = setters.find(key);
    if (setter == setters.end())
      return slamcore::InvalidArgument("config " + path + ": unknown key \"" + key + "\"");
    try {
      setter->second(value);
    } catch (const std::exception& e) {
      return slamcore::InvalidArgument("config " + path + ": key \"" + key + "\": " + e.what());
    }
  }
  return slamcore::Status::Ok();
}

}  // namespace server
