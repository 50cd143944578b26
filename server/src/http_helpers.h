// Helpers the dashboard's HTTP handlers share: JSON responses and errors (HTTP status from the Status
// code), path and query parsing, and bearer-token authorisation for the few POST endpoints. Internal to
// server/.
//
// Thread safety: free functions without shared state.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "server/auth.h"
#include "server/http_server.h"
#include "storage/status.h"

namespace server::http {

HttpResponse Json(const nlohmann::json& body, int status = 200);
/// {"error": message} with `status`.
HttpResponse Error(int status, const std::string& message);
/// {"error": message, "code": "ABORTED"} with the HTTP status matching the code (NOT_FOUND 404, ABORTED and
/// FAILED_PRECONDITION 409, ...).
HttpResponse Error(const slamcore::Status& status);

std::string UrlDecode(const std::string& text);
std::map<std::string, std::string> ParseQuery(const std::string& query);
/// "/api/runs/a%20b" → {"api", "runs", "a b"}.
std::vector<std::string> SplitPath(const std::string& path);
using PathParams = std::map<std::string, std::string>;
/// Matches a path against a template such as "/api/runs/{run}/graph": the segments in braces are returned by
/// name (URL-decoded), the others must be equal; nullopt when the path does not fit.
std::optional<PathParams> MatchPath(const std::string& pattern, const std::string& path);
/// A 400 naming the first of the path's {robot} and {run} segments that no upload could have as its id
/// (analyzer::ValidateId's syntax), checked before any lookup; nullopt when they are well-formed.
std::optional<HttpResponse> RefuseMalformedIds(const PathParams& path);
/// A whole decimal integer, or nullopt.
std::optional<std::int64_t> ParseInt(const std::string& text);
/// A query parameter as an integer in [low, high]; nullopt when absent or empty, and then also when malformed
/// or out of range, with `*error` naming the parameter and what was expected.
std::optional<std::int64_t> IntParam(const std::map<std::string, std::string>& params,
                                     const std::string& name, std::int64_t low, std::int64_t high,
                                     std::string* error);
/// A query parameter's value, empty when absent.
std::string Param(const std::map<std::string, std::string>& params, const std::string& name);

/// Authenticates the request's bearer token and checks `permission`; on failure `*refusal` is the 401/403/503
/// response, naming `what` the caller tried ("labelling", "repairing maps").
std::optional<Principal> AuthorizeRequest(Authenticator& authenticator, const HttpRequest& request,
                                          Permission permission, const std::string& what,
                                          HttpResponse* refusal);

}  // namespace server::http
