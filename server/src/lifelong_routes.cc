#include "server/lifelong_routes.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "http_helpers.h"

namespace server {
namespace {

constexpr std::uintmax_t kMaxResultsBytes = 32u << 20;

HttpResponse Lifelong(const std::string& path) {
  if (path.empty()) {
    return http::Error(404,
                       "no lifelong results: start fleetd with --lifelong-results FILE, written by "
                       "fleetsim --lifelong --results FILE");
  }
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error) return http::Error(404, "no lifelong results yet (the results file cannot be read)");
  if (size > kMaxResultsBytes) return http::Error(413, "the lifelong results file is over 32 MiB");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  nlohmann::json results = nlohmann::json::parse(text.str(), nullptr, /*allow_exceptions=*/false);
  if (results.is_discarded() || !results.is_object() || !results.contains("regimes") ||
      !results["regimes"].is_object()) {
    return http::Error(500, "the lifelong results file is not a fleetsim --lifelong object (no \"regimes\")");
  }
  for (auto& [name, regime] : results["regimes"].items()) {
    if (regime.is_object()) regime.erase("per_robot");  // the page draws the summary only
  }
  results.erase("per_robot_fields");
  return http::Json(results);
}

}  // namespace

void RegisterLifelongRoutes(HttpRouter& router, const FleetdConfig& config) {
  const std::string path = config.lifelong_results;
  router.AddRoute("GET", "/api/lifelong", [path](const HttpRequest&) { return Lifelong(path); });
}

}  // namespace server
