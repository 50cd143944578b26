// fleetd's HTTP transport against a client that misbehaves on purpose (raw sockets on loopback): requests
// that do not parse get their status, a client that trickles or goes silent is cut off at the deadline
// however it spaces its bytes, and one address cannot take every connection.
#include "server/http_server.h"

#include "http_helpers.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>

namespace server {
namespace {

/// A connected socket to 127.0.0.1:port (closed with the object), with a receive timeout so that a test
/// never hangs on a server that keeps the connection open.
class RawClient {
 public:
  explicit RawClient(int port) : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
    timeval timeout{.tv_sec = 20, .tv_usec = 0};
    setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  }
  ~RawClient() { ::close(fd_); }
  bool connected() const { return connected_; }
  bool Send(const std::string& bytes) {
    return ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(bytes.size());
  }
  /// Everything until the server closes (or the receive timeout).
  std::string ReadAll() {
    std::string out;
    char chunk[4096];
    for (ssize_t got; (got = ::recv(fd_, chunk, sizeof chunk, 0)) > 0;) out.append(chunk, got);
    return out;
  }

 private:
  int fd_;
  bool connected_ = false;
};

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

struct Served {
  std::unique_ptr<HttpServer> server;
  int port = 0;
};

Served Serve(HttpServerOptions options) {
  static HttpRouter router = [] {
    HttpRouter r;
    r.AddRoute("GET", "/hello", [](const HttpRequest&) { return HttpResponse{.body = "hello\n"}; });
    return r;
  }();
  std::string error;
  Served served;
  served.server = HttpServer::Create("127.0.0.1:0", router, &error, std::move(options));
  EXPECT_NE(served.server, nullptr) << error;
  const std::string bound = served.server->BoundAddress();
  served.port = std::stoi(bound.substr(bound.rfind(':') + 1));
  served.server->Start();
  return served;
}

TEST(HttpServerTest, RequestsThatDoNotParseGetTheirStatus) {
  Served served = Serve({});
  RawClient malformed(served.port);
  ASSERT_TRUE(malformed.Send("GET /hello HTTP/1.1\r\nHost 127.0.0.1\r\n\r\n"));  // a header without a colon
  EXPECT_EQ(malformed.ReadAll().rfind("HTTP/1.1 400", 0), 0u);
  RawClient oversized(served.port);
  ASSERT_TRUE(oversized.Send("POST /hello HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 5000000\r\n\r\n"));
  EXPECT_EQ(oversized.ReadAll().rfind("HTTP/1.1 413", 0), 0u);
  RawClient huge_header(served.port);
  ASSERT_TRUE(huge_header.Send(
      "GET /hello HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Pad: " + std::string(200'000, 'a') + "\r\n\r\n"));
  EXPECT_EQ(huge_header.ReadAll().rfind("HTTP/1.1 431", 0), 0u);
}

// A proxy in front may read the first copy of a header and fleetd the last: a single-valued header given
// twice is refused by name, whichever it is, while list-valued headers may repeat.
TEST(HttpServerTest, ASingleValuedHeaderGivenTwiceIsRefusedByName) {
  Served served = Serve({});
  for (const std::string header : {"Authorization: Bearer a.b", "Host: 127.0.0.1", "Origin: http://127.0.0.1",
                                   "Content-Type: text/plain", "Cookie: a=1"}) {
    RawClient twice(served.port);
    ASSERT_TRUE(
        twice.Send("GET /hello HTTP/1.1\r\nHost: 127.0.0.1\r\n" + header + "\r\n" + header + "\r\n\r\n"));
    const std::string answer = twice.ReadAll();
    EXPECT_EQ(answer.rfind("HTTP/1.1 400", 0), 0u) << header << "\n" << answer;
    const std::string name = Lower(header.substr(0, header.find(':')));
    // The body is JSON: the name's quotes come escaped.
    EXPECT_NE(answer.find("header \\\"" + name + "\\\" given more than once"), std::string::npos) << answer;
    EXPECT_EQ(answer.find("hello\n"), std::string::npos) << "the route ran";
  }
  RawClient listed(served.port);
  ASSERT_TRUE(
      listed.Send("GET /hello HTTP/1.1\r\nHost: 127.0.0.1\r\nAccept: text/plain\r\nAccept: */*\r\n"
                  "Connection: close\r\n\r\n"));
  const std::string answer = listed.ReadAll();
  EXPECT_EQ(answer.rfind("HTTP/1.1 200", 0), 0u) << answer;
  EXPECT_NE(answer.find("hello\n"), std::string::npos);
}

TEST(HttpServerTest, AClientTricklingItsRequestIsCutOffAtTheDeadline) {
  HttpServerOptions options;
  options.io_timeout_seconds = 1;
  Served served = Serve(options);
  RawClient slow(served.port);
  ASSERT_TRUE(slow.connected());
  // A byte every 200 ms: each receive call returns at once, so only a deadline for the whole request ends it.
  const std::string request = "GET /hello HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Pad: " + std::string(200, 'a');
  const auto started = std::chrono::steady_clock::now();
  bool cut_off = false;
  for (const char c : request) {
    if (!slow.Send(std::string(1, c))) {
      cut_off = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    if (std::chrono::steady_clock::now() - started > std::chrono::seconds(15)) break;
  }
  EXPECT_TRUE(cut_off) << "the server still read a request trickled over 15 s";
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(15));
  // The server still answers others.
  RawClient polite(served.port);
  ASSERT_TRUE(polite.Send("GET /hello HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n"));
  EXPECT_NE(polite.ReadAll().find("hello"), std::string::npos);
}

TEST(HttpServerTest, OneAddressCannotTakeEveryConnection) {
  HttpServerOptions options;
  options.max_connections_per_address = 3;
  Served served = Serve(options);
  std::vector<std::unique_ptr<RawClient>> held;
  for (int k = 0; k < 3; ++k) {
    held.push_back(std::make_unique<RawClient>(served.port));
    ASSERT_TRUE(held.back()->Send("GET /hel"));  // a partial request holds its connection
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  RawClient fourth(served.port);
  fourth.Send("GET /hello HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(fourth.ReadAll(), "");  // closed at once, unanswered
  held.clear();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  RawClient later(served.port);
  ASSERT_TRUE(later.Send("GET /hello HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n"));
  EXPECT_NE(later.ReadAll().find("hello"), std::string::npos);
}

// Path integers: a number past int64's range is refused, not clamped to its maximum.
TEST(HttpHelpersTest, IntegersPastInt64AreNoNumber) {
  EXPECT_EQ(http::ParseInt("42"), 42);
  EXPECT_EQ(http::ParseInt("-7"), -7);
  EXPECT_EQ(http::ParseInt("9223372036854775807"), INT64_MAX);
  EXPECT_EQ(http::ParseInt("99999999999999999999"), std::nullopt);
  EXPECT_EQ(http::ParseInt(""), std::nullopt);
  EXPECT_EQ(http::ParseInt("12abc"), std::nullopt);
  EXPECT_EQ(http::ParseInt(" 12"), std::nullopt);
}

}  // namespace
}  // namespace server
