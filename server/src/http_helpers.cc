#include "http_helpers.h"

#include <algorithm>
#include <charconv>

#include "analyzer/telemetry_codec.h"

namespace server::http {

using json = nlohmann::json;

HttpResponse Json(const json& body, int status) {
  HttpResponse response;
  response.status = status;
  response.content_type = "application/json";
  response.body = body.dump(-1, ' ', false, json::error_handler_t::replace);
  response.headers.emplace_back("Cache-Control", "no-store");
  return response;
}

HttpResponse Error(int status, const std::string& message) { return Json(json{{"error", message}}, status); }

namespace {

// The one mapping from the project's status codes to HTTP's.
int HttpStatusOf(const slamcore::Status& status) {
  switch (status.code()) {
    case slamcore::StatusCode::kOk: return 200;
    case slamcore::StatusCode::kInvalidArgument: return 400;
    case slamcore::StatusCode::kNotFound: return 404;
    case slamcore::StatusCode::kAlreadyExists:
    case slamcore::StatusCode::kFailedPrecondition:
    case slamcore::StatusCode::kAborted: return 409;
    case slamcore::StatusCode::kUnavailable: return 503;
    case slamcore::StatusCode::kDataLoss:
    case slamcore::StatusCode::kInternal: return 500;
  }
  return 500;
}

}  // namespace

HttpResponse Error(const slamcore::Status& status) {
  // The code tells apart what shares an HTTP status (409: ABORTED — the map moved on — or FAILED_PRECONDITION).
  return Json(json{{"error", status.message()}, {"code", slamcore::StatusCodeName(status.code())}},
              HttpStatusOf(status));
}

namespace {

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

std::string UrlDecode(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '+') {
      out += ' ';
    } else if (text[i] == '%' && i + 2 < text.size() && HexValue(text[i + 1]) >= 0 &&
               HexValue(text[i + 2]) >= 0) {
      out += static_cast<char>(HexValue(text[i + 1]) * 16 + HexValue(text[i + 2]));
      i += 2;
    } else {
      out += text[i];
    }
  }
  return out;
}

std::map<std::string, std::string> ParseQuery(const std::string& query) {
  std::map<std::string, std::string> params;
  std::size_t start = 0;
  while (start <= query.size()) {
    const std::size_t end = std::min(query.find('&', start), query.size());
    const std::string pair = query.substr(start, end - start);
    if (!pair.empty()) {
      const std::size_t equals = pair.find('=');
      params[UrlDecode(pair.substr(0, equals))] =
          equals == std::string::npos ? "" : UrlDecode(pair.substr(equals + 1));
    }
    start = end + 1;
  }
  return params;
}

std::vector<std::string> SplitPath(const std::string& path) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (start < path.size()) {
    const std::size_t end = std::min(path.find('/', start), path.size());
    if (end > start) parts.push_back(UrlDecode(path.substr(start, end - start)));
    start = end + 1;
  }
  return parts;
}

std::optional<PathParams> MatchPath(const std::string& pattern, const std::string& path) {
  const std::vector<std::string> want = SplitPath(pattern), got = SplitPath(path);
  if (want.size() != got.size()) return std::nullopt;
  PathParams params;
  for (std::size_t i = 0; i < want.size(); ++i) {
    const std::string& segment = want[i];
    if (segment.size() > 2 && segment.front() == '{' && segment.back() == '}') {
      params[segment.substr(1, segment.size() - 2)] = got[i];
    } else if (segment != got[i]) {
      return std::nullopt;
    }
  }
  return params;
}

std::optional<HttpResponse> RefuseMalformedIds(const PathParams& path) {
  for (const char* name : {"robot", "run"}) {
    const auto it = path.find(name);
    if (it == path.end()) continue;
    // The id is not echoed: it may be kilobytes long or carry what a log should not hold.
    const slamcore::Status bad = analyzer::ValidateId(it->second, std::string(name) + "_id");
    if (!bad.ok()) return Error(400, bad.message());
  }
  return std::nullopt;
}

std::optional<std::int64_t> ParseInt(const std::string& text) {
  // from_chars, not strtoll: a number past int64's range is no number (strtoll clamped it, and
  // 99999999999999999999 became version 9223372036854775807 and a 404 instead of a 400).
  std::int64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

std::optional<std::int64_t> IntParam(const std::map<std::string, std::string>& params,
                                     const std::string& name, std::int64_t low, std::int64_t high,
                                     std::string* error) {
  const auto it = params.find(name);
  if (it == params.end() || it->second.empty()) return std::nullopt;
  const auto value = ParseInt(it->second);
  if (!value || *value < low || *value > high) {
    *error = name + ": expected an integer in [" + std::to_string(low) + ", " + std::to_string(high) +
             "], got \"" + it->second + "\"";
    return std::nullopt;
  }
  return value;
}

std::string Param(const std::map<std::string, std::string>& params, const std::string& name) {
  const auto it = params.find(name);
  return it == params.end() ? std::string() : it->second;
}

std::optional<Principal> AuthorizeRequest(Authenticator& authenticator, const HttpRequest& request,
                                          Permission permission, const std::string& what,
                                          HttpResponse* refusal) {
  const auto header = request.headers.find("authorization");
  Authenticator::Verdict verdict =
      authenticator.Authenticate(header == request.headers.end() ? "" : header->second, request.peer);
  if (verdict.outcome == Authenticator::Outcome::kUnavailable) {
    *refusal = Error(503, verdict.message);
    return std::nullopt;
  }
  if (verdict.outcome != Authenticator::Outcome::kOk) {
    *refusal = Error(401, what + " needs an engineer token (Authorization: Bearer ...): " + verdict.message);
    refusal->headers.emplace_back("WWW-Authenticate", "Bearer");
    return std::nullopt;
  }
  if (!Allows(verdict.principal.role, permission)) {
    *refusal = Error(
        403, verdict.principal.name + " (role " + RoleName(verdict.principal.role) + ") may not do " + what);
    return std::nullopt;
  }
  return verdict.principal;
}

}  // namespace server::http
