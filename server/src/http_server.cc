#include "server/http_server.h"

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include <sys/socket.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string_view>
#include <thread>

namespace server {
namespace {

/// Headers fleetd reads as one value (RFC 9110 §5.3: a field that is no list must not repeat).
bool IsSingleValued(const std::string& lower_name) {
  static constexpr std::array<std::string_view, 7> kSingle = {
      "host", "authorization", "origin", "content-type", "content-length", "cookie", "transfer-encoding"};
  return std::find(kSingle.begin(), kSingle.end(), lower_name) != kSingle.end();
}

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

/// "[::1]:8080" → "::1", "host:8080" → "host", "host" → "host" (lowercase).
std::string HostPart(const std::string& host_header) {
  std::string host = Lower(host_header);
  if (!host.empty() && host.front() == '[') {
    const std::size_t close = host.find(']');
    return close == std::string::npos ? host : host.substr(1, close - 1);
  }
  const std::size_t colon = host.find(':');
  if (colon != std::string::npos && host.find(':', colon + 1) == std::string::npos)
    host = host.substr(0, colon);
  return host;
}

bool HasControlCharacters(std::string_view text) {
  return std::any_of(text.begin(), text.end(), [](unsigned char c) { return c < 0x20 || c == 0x7f; });
}

HttpResponse Refusal(int status, const std::string& message) {
  HttpResponse response;
  response.status = status;
  response.content_type = "application/json";
  std::string escaped;
  for (const char c : message) {
    if (c == '"' || c == '\\') escaped.push_back('\\');
    if (static_cast<unsigned char>(c) >= 0x20) escaped.push_back(c);
  }
  response.body = "{\"error\": \"" + escaped + "\"}";
  return response;
}

// The dashboard loads only its own scripts, styles and images; nothing may frame it.
constexpr const char* kContentSecurityPolicy =
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; "
    "connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'";

}  // namespace

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

void HttpRouter::AddRoute(const std::string& method, const std::string& path_prefix, HttpHandler handler) {
  routes_.push_back(Route{method, path_prefix, std::move(handler)});
}

HttpResponse HttpRouter::Handle(const HttpRequest& request) const {
  if (guard_) {
    try {
      if (auto refusal = guard_(request)) return *refusal;
    } catch (const std::exception& e) {
      HttpResponse response;
      response.status = 500;
      response.body = std::string("internal error: ") + e.what() + "\n";
      return response;
    }
  }
  const Route* best = nullptr;
  bool path_known = false;
  for (const Route& route : routes_) {
    if (request.path.rfind(route.prefix, 0) != 0) continue;
    path_known = true;
    if (route.method != request.method && !(route.method == "GET" && request.method == "HEAD")) continue;
    if (best == nullptr || route.prefix.size() > best->prefix.size()) best = &route;
  }
  if (best == nullptr) {
    HttpResponse response;
    response.status = path_known ? 405 : 404;
    response.body = path_known ? "method not allowed\n" : "not found\n";
    return response;
  }
  try {
    return best->handler(request);
  } catch (const std::exception& e) {
    HttpResponse response;
    response.status = 500;
    response.body = std::string("internal error: ") + e.what() + "\n";
    return response;
  }
}

/// The status a request that failed to parse gets: 413 for a body over the limit, 431 for headers over
/// theirs, 400 for anything else malformed; 0 when the client closed or went silent (nothing to answer).
int ParseRefusalStatus(const beast::error_code& ec) {
  if (ec == http::error::body_limit) return 413;
  if (ec == http::error::header_limit) return 431;
  if (ec == http::error::end_of_stream || ec == http::error::partial_message) return 0;
  return ec.category() == http::make_error_code(http::error::bad_method).category() ? 400 : 0;
}

class HttpServer::Impl {
 public:
  Impl(const HttpRouter& router, HttpServerOptions options)
      : router_(router), options_(std::move(options)), acceptor_(io_) {
    for (std::string& host : options_.allowed_hosts) host = Lower(host);
  }

  bool Bind(const std::string& address, std::string* error) {
    const std::size_t colon = address.rfind(':');
    if (colon == std::string::npos) {
      *error = "http address: expected host:port, got \"" + address + "\"";
      return false;
    }
    beast::error_code ec;
    std::string host = address.substr(0, colon);
    if (host.size() > 2 && host.front() == '[') host = host.substr(1, host.size() - 2);
    const auto ip = asio::ip::make_address(host.empty() ? "0.0.0.0" : host, ec);
    if (ec) {
      *error = "http address: bad host \"" + host + "\": " + ec.message();
      return false;
    }
    int port = 0;
    try {
      port = std::stoi(address.substr(colon + 1));
    } catch (...) {
      port = -1;
    }
    if (port < 0 || port > 65535) {
      *error = "http address: bad port in \"" + address + "\"";
      return false;
    }
    const tcp::endpoint endpoint(ip, static_cast<unsigned short>(port));
    acceptor_.open(endpoint.protocol(), ec);
    if (!ec) acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor_.bind(endpoint, ec);
    if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec) {
      *error = "http: cannot listen on " + address + ": " + ec.message();
      return false;
    }
    bound_ip_ = ip;
    return true;
  }

  std::string BoundAddress() const {
    const auto endpoint = acceptor_.local_endpoint();
    return endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
  }

  void Start() {
    accept_thread_ = std::thread([this] { AcceptLoop(); });
    watchdog_thread_ = std::thread([this] { Watchdog(); });
  }

  void Stop() {
    if (stopping_.exchange(true)) return;
    beast::error_code ec;
    if (accept_thread_.joinable()) {
      // A blocking accept() is not woken by close() on Linux: connect to ourselves instead.
      auto endpoint = acceptor_.local_endpoint(ec);
      if (!ec) {
        if (endpoint.address().is_unspecified()) {
          endpoint.address(endpoint.protocol() == tcp::v6()
                               ? asio::ip::address(asio::ip::address_v6::loopback())
                               : asio::ip::address(asio::ip::address_v4::loopback()));
        }
        tcp::socket waker(io_);
        waker.connect(endpoint, ec);
      }
      accept_thread_.join();
    }
    acceptor_.close(ec);
    {
      std::lock_guard lock(mutex_);
      for (Connection* connection : connections_list_) {
        beast::error_code ignored;
        connection->socket.shutdown(tcp::socket::shutdown_receive, ignored);
      }
    }
    watchdog_wake_.notify_all();
    if (watchdog_thread_.joinable()) watchdog_thread_.join();
    std::unique_lock lock(mutex_);
    idle_.wait(lock, [this] { return connections_ == 0; });
  }

 private:
  void AcceptLoop() {
    while (!stopping_) {
      beast::error_code ec;
      tcp::socket socket(io_);
      acceptor_.accept(socket, ec);
      if (ec) {
        if (stopping_) return;
        continue;
      }
      beast::error_code peer_error;
      const auto remote = socket.remote_endpoint(peer_error);
      const std::string peer = peer_error ? "" : remote.address().to_string();
      std::lock_guard lock(mutex_);
      // Over either cap the connection is closed at once, rather than queueing threads without bound; the
      // per-address cap keeps one client from taking every slot.
      if (connections_ >= options_.max_connections ||
          per_peer_[peer] >= options_.max_connections_per_address) {
        socket.close(ec);
        continue;
      }
      ++connections_;
      ++per_peer_[peer];
      auto connection = std::make_unique<Connection>(std::move(socket), peer);
      connections_list_.push_back(connection.get());
      std::thread([this, owned = std::move(connection)]() mutable { Serve(std::move(owned)); }).detach();
    }
  }

  /// The Host header names this server: the allow-list, the bound address, loopback names on a loopback
  /// binding, any IP literal on a wildcard binding (a DNS-rebinding page always sends a host *name*).
  bool HostAllowed(const std::string& host_header) const {
    if (host_header.empty()) return false;
    const std::string lowered = Lower(host_header), host = HostPart(host_header);
    for (const std::string& allowed : options_.allowed_hosts) {
      if (allowed == lowered || allowed == host) return true;
    }
    if (host == "localhost") return true;  // a rebinding page cannot make a browser send it
    beast::error_code ec;
    const auto literal = asio::ip::make_address(host, ec);
    if (bound_ip_.is_unspecified()) return !ec;
    if (!ec && literal == bound_ip_) return true;
    if (bound_ip_.is_loopback()) return host == "localhost" || (!ec && literal.is_loopback());
    return false;
  }

  /// Transport-level checks before routing; a refusal or nullopt.
  std::optional<HttpResponse> Screen(const HttpRequest& request) const {
    if (request.path == "/healthz" || request.path == "/livez") return std::nullopt;
    const auto host = request.headers.find("host");
    const std::string host_value = host == request.headers.end() ? "" : host->second;
    if (!HostAllowed(host_value)) {
      return Refusal(421, "host: \"" + host_value + "\" is not this server (see --http-allowed-hosts)");
    }
    if (request.method != "GET" && request.method != "HEAD") {
      const auto origin = request.headers.find("origin");
      if (origin != request.headers.end() && Lower(origin->second) != "http://" + Lower(host_value) &&
          Lower(origin->second) != "https://" + Lower(host_value)) {
        return Refusal(403, "origin: \"" + origin->second + "\" may not write to this server");
      }
    }
    return std::nullopt;
  }

  /// One connection: its socket, its peer, and by when its current read or write must be done.
  struct Connection {
    Connection(tcp::socket accepted, std::string from) : socket(std::move(accepted)), peer(std::move(from)) {}
    tcp::socket socket;
    const std::string peer;
    /// Steady-clock nanoseconds by which the request being read, or the response being written, must be
    /// through; 0 while a handler runs. The watchdog shuts the socket down past it.
    std::atomic<std::int64_t> deadline{0};
  };

  static std::int64_t Now() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }

  /// Every request must arrive, and every response leave, within the I/O timeout, however the client
  /// trickles its bytes: a socket past its deadline is shut down, which ends the blocking read or write
  /// (a timeout per receive call would let a client sending a byte now and then hold its thread forever).
  void Watchdog() {
    std::unique_lock lock(mutex_);
    while (!stopping_) {
      watchdog_wake_.wait_for(lock, std::chrono::milliseconds(200));
      const std::int64_t now = Now();
      for (Connection* connection : connections_list_) {
        const std::int64_t deadline = connection->deadline.load();
        if (deadline != 0 && now > deadline) {
          ::shutdown(connection->socket.native_handle(), SHUT_RDWR);
          connection->deadline = 0;
        }
      }
    }
  }

  void Serve(std::unique_ptr<Connection> owned) {
    Connection& connection = *owned;
    tcp::socket& socket = connection.socket;
    const std::string& peer = connection.peer;
    const std::int64_t timeout = std::int64_t{options_.io_timeout_seconds} * 1'000'000'000;
    beast::flat_buffer buffer;
    while (!stopping_) {
      http::request_parser<http::string_body> parser;
      parser.body_limit(1 << 20);
      beast::error_code ec;
      connection.deadline = Now() + timeout;
      http::read(socket, buffer, parser, ec);
      connection.deadline = 0;
      HttpRequest request;
      HttpResponse handled;
      unsigned version = 11;
      bool keep_alive = false;
      if (ec) {
        // A request that does not parse or is too large gets its status before the connection closes
        // (none when the client went away or the deadline cut it off).
        const int status = ParseRefusalStatus(ec);
        if (status == 0) break;
        handled = Refusal(status, "malformed or oversized request: " + ec.message());
      } else {
        const auto& message = parser.get();
        version = message.version();
        keep_alive = message.keep_alive();
        request.method = std::string(message.method_string());
        request.target = std::string(message.target());
        const std::size_t question = request.target.find('?');
        request.path = request.target.substr(0, question);
        request.query = question == std::string::npos ? "" : request.target.substr(question + 1);
        std::string repeated;  // a single-valued header given twice
        for (const auto& field : message) {
          std::string name(field.name_string());
          std::transform(name.begin(), name.end(), name.begin(),
                         [](unsigned char c) { return std::tolower(c); });
          const bool inserted = request.headers.try_emplace(name, field.value()).second;
          if (!inserted && repeated.empty() && IsSingleValued(name)) repeated = name;
        }
        request.body = message.body();
        request.peer = peer;
        if (!repeated.empty()) {
          // Which copy counts differs between a proxy in front and fleetd: refuse rather than pick one.
          handled = Refusal(400, "header \"" + repeated + "\" given more than once");
          keep_alive = false;
        } else {
          auto screened = Screen(request);
          handled = screened ? std::move(*screened) : router_.Handle(request);
        }
      }
      const bool unsafe_header =
          std::any_of(handled.headers.begin(), handled.headers.end(), [](const auto& header) {
            return HasControlCharacters(header.first) || HasControlCharacters(header.second);
          });
      if (unsafe_header || HasControlCharacters(handled.content_type)) {
        handled = Refusal(500, "internal error: a response header carried control characters");
      }
      http::response<http::string_body> response{static_cast<http::status>(handled.status), version};
      response.set(http::field::server, "fleetd");
      response.set(http::field::content_type, handled.content_type);
      for (const auto& [name, value] : handled.headers) response.set(name, value);
      response.set("X-Content-Type-Options", "nosniff");
      response.set(http::field::x_frame_options, "DENY");
      response.set("Referrer-Policy", "no-referrer");
      response.set("Content-Security-Policy", kContentSecurityPolicy);
      if (request.path.rfind("/static/", 0) != 0) response.set(http::field::cache_control, "no-store");
      response.keep_alive(keep_alive && !stopping_);
      if (request.method != "HEAD") response.body() = handled.body;
      response.prepare_payload();
      if (request.method == "HEAD") response.body().clear();
      connection.deadline = Now() + timeout;
      http::write(socket, response, ec);
      connection.deadline = 0;
      if (ec || !response.keep_alive()) break;
    }
    beast::error_code ignored;
    socket.shutdown(tcp::socket::shutdown_both, ignored);
    std::lock_guard lock(mutex_);
    connections_list_.erase(std::remove(connections_list_.begin(), connections_list_.end(), &connection),
                            connections_list_.end());
    if (--per_peer_[peer] == 0) per_peer_.erase(peer);
    // Destroyed before the count drops: once it is 0 the server may destroy io_, whose socket service a
    // socket's destructor uses.
    owned.reset();
    --connections_;
    idle_.notify_all();
  }

  const HttpRouter router_;
  HttpServerOptions options_;
  asio::ip::address bound_ip_;
  asio::io_context io_;
  tcp::acceptor acceptor_;
  std::thread accept_thread_, watchdog_thread_;
  std::atomic<bool> stopping_{false};
  std::mutex mutex_;  // guards connections_, connections_list_, per_peer_
  std::condition_variable idle_, watchdog_wake_;
  int connections_ = 0;
  std::vector<Connection*> connections_list_;
  std::map<std::string, int> per_peer_;  // open connections by peer address
};

std::unique_ptr<HttpServer> HttpServer::Create(const std::string& address, const HttpRouter& router,
                                               std::string* error, HttpServerOptions options) {
  auto impl = std::make_unique<Impl>(router, std::move(options));
  if (!impl->Bind(address, error)) return nullptr;
  return std::unique_ptr<HttpServer>(new HttpServer(std::move(impl)));
}

HttpServer::HttpServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
HttpServer::~HttpServer() { Stop(); }
std::string HttpServer::BoundAddress() const { return impl_->BoundAddress(); }
void HttpServer::Start() { impl_->Start(); }
void HttpServer::Stop() { impl_->Stop(); }

}  // namespace server
