// Who may read what over HTTP: the same tokens and roles as gRPC (server/auth.h). docs/formats/service.md,
// "HTTP", is the contract; this file is its one implementation.
//
//   open              GET /healthz, /livez, and the dashboard's shell (/, /index.html, /static/...): no data in them
//   /metrics          engineer or admin token, or anyone with --metrics-open
//   /api/...          a token: engineers and admins read the fleet (writes check their own permission);
//                     robots read only /api/robots/<own id>/... and /api/runs/<own run>/..., GET only
#include "http_helpers.h"
#include "server/dashboard_routes.h"

namespace server {
namespace {

bool IsOpen(const HttpRequest& request, bool metrics_open) {
  const bool read = request.method == "GET" || request.method == "HEAD";
  if (!read) return false;
  if (request.path == "/healthz" || request.path == "/livez" || request.path == "/" ||
      request.path == "/index.html")
    return true;
  if (request.path.rfind("/static/", 0) == 0) return true;
  return metrics_open && request.path == "/metrics";
}

}  // namespace

HttpGuard MakeHttpAccessGuard(storage::Repository& repository, Authenticator& authenticator,
                              const FleetdConfig& config) {
  const bool metrics_open = config.metrics_open;
  return
      [&repository, &authenticator, metrics_open](const HttpRequest& request) -> std::optional<HttpResponse> {
        if (IsOpen(request, metrics_open)) return std::nullopt;
        HttpResponse refusal;
        const auto header = request.headers.find("authorization");
        const Authenticator::Verdict verdict =
            authenticator.Authenticate(header == request.headers.end() ? "" : header->second, request.peer);
        if (verdict.outcome == Authenticator::Outcome::kUnavailable) return http::Error(503, verdict.message);
        if (verdict.outcome != Authenticator::Outcome::kOk) {
          refusal = http::Error(
              401, "a token is needed (Authorization: Bearer <principal>.<secret>): " + verdict.message);
          refusal.headers.emplace_back("WWW-Authenticate", "Bearer");
          return refusal;
        }
        const Principal& caller = verdict.principal;
        if (caller.role != Role::kRobot)
          return std::nullopt;  // engineers and admins: the handlers decide writes
        const std::string denied = caller.name + " may read only its own runs and map";
        if (request.method != "GET" && request.method != "HEAD") return http::Error(403, denied);
        const std::vector<std::string> parts = http::SplitPath(request.path);
        if (parts.size() >= 3 && parts[0] == "api" && parts[1] == "robots" && parts[2] == caller.id)
          return std::nullopt;
        if (parts.size() >= 3 && parts[0] == "api" && parts[1] == "runs") {
          if (auto malformed = http::RefuseMalformedIds({{"run", parts[2]}})) return malformed;
          // Another robot's run answers exactly like a missing one: its existence is not revealed.
          auto run = repository.GetRun(storage::RunKey{caller.id, parts[2]});
          if (run.ok()) return std::nullopt;
          if (!run.ok() && run.status().code() != storage::StatusCode::kNotFound)
            return http::Error(run.status());
          return http::Error(404, "run " + parts[2] + ": not found");
        }
        return http::Error(403, denied);
      };
}

}  // namespace server
