// fleetd's HTTP side: /metrics (Prometheus text), /healthz, and whatever else registers a route (the
// dashboard adds /api/... and static files). Boost.Beast stays inside http_server.cc.
//
// Routing: AddRoute(method, path_prefix, handler); the longest matching prefix wins ("/api/" matches
// "/api/runs"; "/healthz" matches only paths starting with it). Unknown paths are 404, a known path with
// another method 405. Handlers run on the connection's thread and must be thread-safe.
//
// Access (docs/formats/service.md, "HTTP"): the server checks the Host header against its bound address and
// `HttpServerOptions::allowed_hosts` (every path but /healthz), the Origin of writes against the Host, adds
// the security headers to every response (CSP, nosniff, frame-ancestors, Referrer-Policy; no-store on
// everything but static assets), refuses response headers carrying control characters, caps connections
// and times out slow clients. The router's guard (SetGuard) then decides who may read what.
//
// Thread safety: register routes and the guard before Start(); after that the router is read-only. Stop()
// is safe from any thread and waits for open connections to finish their current request.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace server {

struct HttpRequest {
  std::string method;                          // "GET", "POST", ...
  std::string target;                          // path and query, as sent
  std::string path;                            // target without the query
  std::string query;                           // after '?', undecoded
  std::map<std::string, std::string> headers;  // lowercase names
  std::string body;
  std::string peer;  // the client's address, without the port
};

struct HttpResponse {
  int status = 200;
  std::string content_type = "text/plain; charset=utf-8";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;
};

using HttpHandler = std::function<HttpResponse(const HttpRequest&)>;
/// Runs before routing; a response refuses the request (401, 403, ...), nullopt lets it through.
using HttpGuard = std::function<std::optional<HttpResponse>(const HttpRequest&)>;

class HttpRouter {
 public:
  void AddRoute(const std::string& method, const std::string& path_prefix, HttpHandler handler);
  void SetGuard(HttpGuard guard) { guard_ = std::move(guard); }
  HttpResponse Handle(const HttpRequest& request) const;

 private:
  struct Route {
    std::string method, prefix;
    HttpHandler handler;
  };
  std::vector<Route> routes_;
  HttpGuard guard_;
};

struct HttpServerOptions {
  /// Host names (or host:port) accepted in the Host header besides the bound address and "localhost"; the
  /// loopback addresses are accepted on a loopback binding, any IP literal on a wildcard (0.0.0.0) binding.
  std::vector<std::string> allowed_hosts;
  int max_connections = 256;             // more are closed at once
  int max_connections_per_address = 32;  // from one peer address; more are closed at once
  int io_timeout_seconds = 30;           // a request must arrive, and a response leave, within this
};

class HttpServer {
 public:
  /// Binds `address` ("host:port", port 0 = any free port) at once; fails with a message when it cannot.
  static std::unique_ptr<HttpServer> Create(const std::string& address, const HttpRouter& router,
                                            std::string* error, HttpServerOptions options = {});
  ~HttpServer();
  /// "127.0.0.1:41235": the bound address.
  std::string BoundAddress() const;
  void Start();
  void Stop();

 private:
  class Impl;
  explicit HttpServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace server
