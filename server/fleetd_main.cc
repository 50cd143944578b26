// fleetd: the fleet telemetry analysis server (gRPC API, analysis workers, /metrics and /healthz).
//
//   fleetd [--config FILE] [--db URL] [--listen ADDR] [--http ADDR] [--role all|server|worker] [--workers N] ...
//
// The first line on stdout is one JSON object with the bound addresses, e.g.
// {"grpc": "127.0.0.1:41234", "http": "127.0.0.1:41235"} (port 0 in a flag picks a free port). Logs are
// JSON lines on stderr. SIGTERM/SIGINT: graceful shutdown, exit 0. docs/fleetd.md describes the options.
#include <CLI/CLI.hpp>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <thread>
#include <unistd.h>

#include "server/auth.h"
#include "server/config.h"
#include "server/dashboard_routes.h"
#include "server/lifelong_routes.h"
#include "server/fleet_server.h"
#include "server/health.h"
#include "server/http_server.h"
#include "server/log.h"
#include "server/metrics.h"
#include "server/retention.h"
#include "server/worker_pool.h"

namespace {

std::string JsonQuoted(const std::string& value) {
  std::string out = "\"";
  for (char c : value) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

int main(int argc, char** argv) {
  server::FleetdConfig config;
  // The config file comes first so that flags override it.
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::string(argv[i]) == "--config") {
      if (slamcore::Status loaded = server::LoadConfigFile(argv[i + 1], config); !loaded.ok()) {
        std::cerr << "fleetd: " << loaded.ToString() << "\n";
        return 2;
      }
    }
  }
  // Secrets come through the environment (or the config file), never argv: /proc/PID/cmdline is world-readable.
  if (const char* token = std::getenv("FLEETD_BOOTSTRAP_ADMIN_TOKEN"); token != nullptr && *token != '\0') {
    config.bootstrap_admin_token = token;
  }
  if (const char* url = std::getenv("FLEETD_DB_URL"); url != nullptr && *url != '\0') config.db = url;

  CLI::App app{"fleetd: fleet telemetry analysis server"};
  std::string config_path;
  app.add_option("--config", config_path, "JSON config file (flags override it)");
  app.add_option(
      "--db", config.db,
      "storage URL: sqlite:PATH or postgresql://... (default $FLEETD_DB_URL; a URL with a password "
      "belongs in the environment, not on the command line; default sqlite:fleet.db)");
  app.add_option("--listen", config.listen, "gRPC address host:port (port 0: any free port)")
      ->capture_default_str();
  app.add_option("--http", config.http, "HTTP address for /metrics and /healthz (empty: off)")
      ->capture_default_str();
  app.add_option("--http-allowed-hosts", config.http_allowed_hosts,
                 "comma-separated Host header names the HTTP side answers besides its bound address");
  app.add_flag("--metrics-open", config.metrics_open,
               "serve /metrics without a token (default: engineer token)");
  app.add_option(
      "--lifelong-results", config.lifelong_results,
      "serve this fleetsim --lifelong --results file to the dashboard's fleet page (/api/lifelong)");
  app.add_option("--role", config.role, "all, server (API only) or worker (workers only)")
      ->capture_default_str();
  app.add_option("--workers", config.workers, "analysis worker threads (0: one per core)")
      ->capture_default_str();
  app.add_option("--tls-cert", config.tls_cert, "PEM certificate chain: serve gRPC over TLS");
  app.add_option("--tls-key", config.tls_key, "PEM private key for --tls-cert");
  app.add_option("--bootstrap-admin-token", config.bootstrap_admin_token,
                 "admin token (admin:<name>.<secret>) installed at start while no admin exists; prefer "
                 "$FLEETD_BOOTSTRAP_ADMIN_TOKEN");
  app.add_flag("--bootstrap-admin-force", config.bootstrap_admin_force,
               "install the bootstrap admin token even when an admin exists (recovery; undoes its rotation)");
  app.add_option("--max-message-bytes", config.max_message_bytes, "largest gRPC message")
      ->capture_default_str();
  app.add_option("--max-events-per-run", config.max_events_per_run, "largest run, in events")
      ->capture_default_str();
  app.add_option("--max-run-bytes", config.max_run_bytes, "largest upload stream, in bytes")
      ->capture_default_str();
  app.add_option("--max-upload-streams", config.max_upload_streams, "upload streams in flight, in all")
      ->capture_default_str();
  app.add_option("--max-upload-streams-per-principal", config.max_upload_streams_per_principal,
                 "upload streams in flight per principal")
      ->capture_default_str();
  app.add_option("--max-upload-bytes-in-flight", config.max_upload_bytes_in_flight,
                 "bytes buffered by uploads in flight, in all")
      ->capture_default_str();
  app.add_option("--max-upload-bytes-per-principal", config.max_upload_bytes_per_principal,
                 "bytes buffered by one principal's uploads in flight (>= --max-run-bytes)")
      ->capture_default_str();
  app.add_option("--health-probe-seconds", config.health_probe_seconds,
                 "database write probe interval for /healthz and gRPC health")
      ->capture_default_str();
  app.add_option("--rate-limit", config.rate_limit_per_second, "requests per second per principal (0: off)")
      ->capture_default_str();
  app.add_option("--rate-burst", config.rate_limit_burst, "burst size of the rate limit")
      ->capture_default_str();
  app.add_option("--shutdown-grace", config.shutdown_grace_seconds, "seconds in-flight work gets on SIGTERM")
      ->capture_default_str();
  app.add_option("--default-parameter-set", config.default_parameter_set, "set every upload is analysed with")
      ->capture_default_str();
  app.add_option("--model-name", config.model_name, "classifier model whose active version labels regions")
      ->capture_default_str();
  app.add_option("--analysis-budget-seconds", config.analysis_budget_seconds,
                 "longest one run's analysis may take; then its job fails (<= 0: no limit)")
      ->capture_default_str();
  app.add_option("--lease-seconds", config.lease_seconds, "job lease duration")->capture_default_str();
  app.add_option("--auth-cache-seconds", config.auth_cache_seconds, "verified tokens are cached this long")
      ->capture_default_str();
  app.add_option("--log-level", config.log_level, "debug, info, warn, error")->capture_default_str();
  app.add_option("--log-format", config.log_format, "json or text")->capture_default_str();
  app.add_option(
         "--auto-repair", config.auto_repair,
         "none; cut_protrusions: cut protrusions out of maps after analysis; repair_findings: also reject "
         "unconfirmed hypotheses and high-residual edges, rolling back when one cannot be repaired")
      ->capture_default_str();
  app.add_option("--auto-repair-min-severity", config.auto_repair_min_severity,
                 "the repair policy acts only on findings at least this severe (0..1)")
      ->capture_default_str();
  app.add_option("--auto-repair-protrusions", config.auto_repair_protrusions,
                 "views: the policy cuts only the protrusions the run's own views show (a slip), leaving the "
                 "map-only model's calls to an engineer; any: every protrusion finding")
      ->capture_default_str();
  app.add_flag("--auto-approve", config.auto_approve,
               "policy repairs reach robots without an engineer's review");
  app.add_option(
         "--retain-runs-days", config.retain_runs_days,
         "drop run events (telemetry) uploaded longer ago; reports and map versions are kept (0: never)")
      ->capture_default_str();
  app.add_option("--retain-jobs-days", config.retain_jobs_days, "delete jobs finished longer ago (0: never)")
      ->capture_default_str();
  app.add_option("--retention-interval-seconds", config.retention_interval_seconds,
                 "how often retention runs")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (slamcore::Status valid = config.Validate(); !valid.ok()) {
    std::cerr << "fleetd: " << valid.ToString() << "\n";
    return 2;
  }
  server::log::Configure(config.log_level, config.log_format);

  // Signals are taken by sigwait in main; every thread started below inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  auto repository = storage::OpenRepository(config.db);
  if (!repository.ok()) {
    server::log::Error("open_failed", {{"db", storage::RedactDatabaseUrl(config.db)},
                                       {"error", repository.status().ToString()}});
    return 1;
  }
  storage::Repository& repo = **repository;
  if (slamcore::Status ensured = server::EnsureDefaultParameterSet(repo, config.default_parameter_set);
      !ensured.ok()) {
    server::log::Error("default_parameter_set_failed", {{"error", ensured.ToString()}});
    return 1;
  }
  server::Authenticator authenticator(repo, std::chrono::seconds(config.auth_cache_seconds));
  if (!config.bootstrap_admin_token.empty() && config.role != "worker") {
    auto installed =
        authenticator.InstallBootstrapToken(config.bootstrap_admin_token, config.bootstrap_admin_force);
    if (!installed.ok()) {
      server::log::Error("bootstrap_token_failed", {{"error", installed.status().ToString()}});
      return 2;
    }
    using Outcome = server::Authenticator::BootstrapOutcome;
    if (*installed == Outcome::kInstalled) {
      server::log::Info("bootstrap_token_installed", {{"forced", config.bootstrap_admin_force}});
    } else if (*installed == Outcome::kSkippedAdminExists) {
      server::log::Info("bootstrap_token_skipped",
                        {{"reason",
                          "an admin credential exists (a rotation or revocation is kept); "
                          "--bootstrap-admin-force installs it anyway"}});
    }
  }

  server::Metrics metrics;
  metrics.AddCollector([&repo](server::Metrics& m) {
    for (auto state : {storage::JobState::kQueued, storage::JobState::kLeased}) {
      auto jobs = repo.ListJobs(state, 1000000);
      if (jobs.ok()) {
        m.SetGauge("fleetd_job_queue_depth", "state=\"" + std::string(storage::Name(state)) + "\"",
                   static_cast<double>(jobs->size()));
      }
    }
  });

  char host[256] = "fleetd";
  gethostname(host, sizeof host - 1);
  std::unique_ptr<server::WorkerPool> workers;
  if (config.role != "server") {
    server::WorkerOptions options;
    options.threads = config.workers > 0 ? config.workers : std::max(1u, std::thread::hardware_concurrency());
    options.name = std::string(host) + ":" + std::to_string(::getpid());
    options.lease = std::chrono::seconds(config.lease_seconds);
    options.analysis_budget_seconds = config.analysis_budget_seconds;
    options.model_name = config.model_name;
    options.map_policy = server::MapPolicyOf(config);
    workers = std::make_unique<server::WorkerPool>(repo, metrics, options);
    workers->Start();
  }

  std::unique_ptr<server::FleetServer> grpc_server;
  if (config.role != "worker") {
    server::WorkerPool* local = workers.get();
    auto created = server::FleetServer::Create(config, repo, metrics, authenticator, [local] {
      if (local != nullptr) local->Wake();
    });
    if (!created.ok()) {
      server::log::Error("grpc_failed", {{"error", created.status().ToString()}});
      if (workers) workers->Stop();
      return 1;
    }
    grpc_server = std::move(created).value();
  }
  // Retention in one place: the API servers (workers only lease jobs).
  std::unique_ptr<server::RetentionTask> retention;
  if (config.role != "worker") {
    server::RetentionPolicy policy;
    policy.retain_runs_days = config.retain_runs_days;
    policy.retain_jobs_days = config.retain_jobs_days;
    policy.interval =
        std::chrono::milliseconds(static_cast<long long>(config.retention_interval_seconds * 1000));
    retention = std::make_unique<server::RetentionTask>(repo, metrics, policy);
    retention->Start();
  }

  server::HttpRouter router;
  router.AddRoute("GET", "/metrics", [&metrics](const server::HttpRequest&) {
    server::HttpResponse response;
    response.content_type = "text/plain; version=0.0.4; charset=utf-8";
    response.body = metrics.Render();
    return response;
  });
  server::FleetServer* health_target = grpc_server.get();
  server::HealthMonitor health(
      repo, std::string(host) + ":" + std::to_string(::getpid()),
      std::chrono::milliseconds(static_cast<long long>(config.health_probe_seconds * 1000)),
      [health_target](bool healthy) {
        if (health_target != nullptr) health_target->SetServing(healthy);
        if (!healthy) server::log::Warn("unhealthy", {{"hint", "see /healthz"}});
      });
  health.Start();
  router.AddRoute("GET", "/healthz", [&health](const server::HttpRequest&) {
    server::HttpResponse response;
    const server::HealthMonitor::State state = health.Current();
    response.status = state.healthy ? 200 : 503;
    response.body = state.healthy ? "ok\n" : "storage: " + state.reason + "\n";
    return response;
  });
  // Liveness: the process answers (a full database is no reason to restart it; /healthz is readiness).
  router.AddRoute("GET", "/livez", [](const server::HttpRequest&) {
    server::HttpResponse response;
    response.body = "ok\n";
    return response;
  });
  server::RegisterDashboardRoutes(router, repo, authenticator, config);
  server::RegisterMapRoutes(router, repo, authenticator, config);
  server::RegisterLifelongRoutes(router, config);
  router.SetGuard(server::MakeHttpAccessGuard(repo, authenticator, config));
  std::unique_ptr<server::HttpServer> http;
  if (!config.http.empty()) {
    std::string error;
    server::HttpServerOptions http_options;
    http_options.allowed_hosts = server::SplitList(config.http_allowed_hosts);
    http = server::HttpServer::Create(config.http, router, &error, http_options);
    if (!http) {
      server::log::Error("http_failed", {{"error", error}});
      health.Stop();
      if (retention) retention->Stop();
      if (grpc_server) grpc_server->Shutdown(std::chrono::system_clock::now());
      if (workers) workers->Stop();
      return 1;
    }
    http->Start();
  }

  std::string line =
      "{\"grpc\": " + (grpc_server ? JsonQuoted(grpc_server->BoundAddress()) : std::string("null")) +
      ", \"http\": " + (http ? JsonQuoted(http->BoundAddress()) : std::string("null")) + "}";
  std::cout << line << std::endl;
  server::log::Info("started", {{"grpc", grpc_server ? grpc_server->BoundAddress() : ""},
                                {"http", http ? http->BoundAddress() : ""},
                                {"role", config.role},
                                {"db", storage::RedactDatabaseUrl(config.db)}});

  int signal_number = 0;
  sigwait(&signals, &signal_number);
  server::log::Info("shutting_down", {{"signal", signal_number}});
  const auto deadline =
      std::chrono::system_clock::now() +
      std::chrono::milliseconds(static_cast<long long>(config.shutdown_grace_seconds * 1000));
  health.Stop();
  if (retention) retention->Stop();
  if (grpc_server) grpc_server->Shutdown(deadline);
  if (workers) workers->Stop();
  if (http) http->Stop();
  server::log::Info("stopped");
  return 0;
}
