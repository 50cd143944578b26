// fleetd's configuration: defaults here, then a JSON config file (--config), then command-line flags, each
// overriding the one before. docs/fleetd.md lists the keys: mostly the flag names with '_' for '-' (e.g.
// "max_events_per_run"; three differ). Unknown keys and wrongly typed values are refused, naming the key.
//
// Thread safety: value type.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "slamcore/status.h"

namespace server {

struct FleetdConfig {
  std::string db = "sqlite:fleet.db";      // storage URL: sqlite:PATH or postgresql://...
  std::string listen = "127.0.0.1:50051";  // gRPC; port 0 picks a free port
  std::string http = "127.0.0.1:8080";     // /metrics, /healthz; empty disables
  std::string http_allowed_hosts;          // comma-separated Host names accepted besides the bound address
  std::string lifelong_results;            // fleetsim --lifelong --results FILE, served at /api/lifelong
  bool metrics_open = false;               // /metrics without a token (e.g. a scraper on a private network)
  std::string role = "all";                // "all", "server" (API only), "worker" (workers only)
  int workers = 0;                         // analysis threads; 0: one per core (at least 1)
  std::string tls_cert;                    // PEM files; both set: the gRPC port speaks TLS only
  std::string tls_key;
  std::string bootstrap_admin_token;   // "<admin:name>.<secret>", also env FLEETD_BOOTSTRAP_ADMIN_TOKEN
  bool bootstrap_admin_force = false;  // install it even when an admin exists (undoes a rotation)
  std::int64_t max_message_bytes = 16 << 20;  // one gRPC message
  std::int64_t max_events_per_run = 2'000'000;
  std::int64_t max_run_bytes = 512LL << 20;                   // one whole upload stream
  int max_upload_streams = 64;                                // upload streams in flight, in all
  int max_upload_streams_per_principal = 4;                   // ... per principal
  std::int64_t max_upload_bytes_in_flight = 1LL << 30;        // bytes buffered by uploads in flight, in all
  std::int64_t max_upload_bytes_per_principal = 512LL << 20;  // ... per principal (>= max_run_bytes)
  double health_probe_seconds = 5.0;     // write probe interval; a failed write is unhealthy for 3 of them
  double rate_limit_per_second = 100.0;  // per principal; 0: unlimited
  double rate_limit_burst = 200.0;
  double shutdown_grace_seconds = 20.0;           // SIGTERM: in-flight RPCs and jobs get this long
  std::string default_parameter_set = "default";  // what every upload is analysed with
  std::string model_name = "protrusion";          // the active version of this model classifies regions
  int lease_seconds = 120;
  double analysis_budget_seconds = 600.0;  // one run's analysis; past it the job fails with a clear error
  int auth_cache_seconds = 60;
  std::string log_level = "info";
  std::string log_format = "json";        // "json" or "text"
  std::string auto_repair = "none";       // "none", "cut_protrusions" or "repair_findings" (MapPolicy)
  double auto_repair_min_severity = 0.0;  // the policy acts on findings at least this severe (0..1)
  std::string auto_repair_protrusions = "views";  // "views" or "any": which protrusions it cuts (MapPolicy)
  bool auto_approve = false;                      // policy repairs reach robots without an engineer's review
  double retain_runs_days = 0.0;  // run events older than this are dropped (reports, maps kept); 0: never
  double retain_jobs_days = 7.0;  // finished jobs older than this are deleted; 0: never
  double retention_interval_seconds = 3600.0;  // how often the server applies retention

  /// Checks ranges and enumerations, naming the key, and refuses placeholder or weak secrets (the bootstrap
  /// token's secret, the database URL's password; server/secrets.h).
  slamcore::Status Validate() const;
};

/// "a, b,c" → {"a", "b", "c"} (empty items dropped).
std::vector<std::string> SplitList(const std::string& text);

/// Reads a JSON object of config keys over `config`.
slamcore::Status LoadConfigFile(const std::string& path, FleetdConfig& config);

}  // namespace server
