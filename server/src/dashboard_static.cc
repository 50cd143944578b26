#include "dashboard_static.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "http_helpers.h"
#include "server/log.h"

#ifndef FLEETD_WEB_DIR_DEFAULT
#define FLEETD_WEB_DIR_DEFAULT ""
#endif

namespace server {
namespace {

using http::Error;
using http::SplitPath;

std::string ContentTypeOf(const std::string& path) {
  static const std::map<std::string, std::string> kTypes = {{".html", "text/html; charset=utf-8"},
                                                            {".js", "text/javascript; charset=utf-8"},
                                                            {".mjs", "text/javascript; charset=utf-8"},
                                                            {".css", "text/css; charset=utf-8"},
                                                            {".json", "application/json"},
                                                            {".png", "image/png"},
                                                            {".svg", "image/svg+xml"},
                                                            {".map", "application/json"},
                                                            {".ico", "image/x-icon"}};
  const std::string extension = std::filesystem::path(path).extension().string();
  const auto it = kTypes.find(extension);
  return it == kTypes.end() ? "application/octet-stream" : it->second;
}

/// Only plain relative paths: no "..", no empty or hidden segments, a conservative character set.
bool SafeRelativePath(const std::string& path) {
  if (path.empty() || path.size() > 256) return false;
  for (const std::string& part : SplitPath(path)) {
    if (part.empty() || part[0] == '.') return false;
  }
  return std::all_of(path.begin(), path.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '_' || c == '-' || c == '/';
  });
}

HttpResponse ServeFile(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in || std::filesystem::is_directory(file)) return Error(404, "not found");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  HttpResponse response;
  response.content_type = ContentTypeOf(file.string());
  response.body = bytes.str();
  response.headers.emplace_back("Cache-Control", "no-cache");
  return response;
}

std::filesystem::path ResolveWebDir() {
  if (const char* env = std::getenv("FLEETD_WEB_DIR"); env != nullptr && *env != '\0') return env;
  const std::filesystem::path built = FLEETD_WEB_DIR_DEFAULT;
  std::error_code ec;
  if (!built.empty() && std::filesystem::exists(built / "index.html", ec)) return built;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path("web") : exe.parent_path() / "web";
}

HttpResponse Static(const std::filesystem::path& web_dir, const HttpRequest& request) {
  if (request.path == "/" || request.path == "/index.html") return ServeFile(web_dir / "index.html");
  const std::string prefix = "/static/";
  if (request.path.rfind(prefix, 0) != 0) return Error(404, "not found: " + request.path);
  const std::string relative = request.path.substr(prefix.size());
  if (!SafeRelativePath(relative)) return Error(404, "not found");
  const std::string vendor = "vendor/chart.js/";
  if (relative.rfind(vendor, 0) == 0) {
    return ServeFile(web_dir / "node_modules" / "chart.js" / "dist" / relative.substr(vendor.size()));
  }
  if (relative.rfind("node_modules", 0) == 0) return Error(404, "not found");
  return ServeFile(web_dir / relative);
}

}  // namespace

void RegisterStaticRoutes(HttpRouter& router) {
  const std::filesystem::path web_dir = ResolveWebDir();
  log::Info("dashboard_web_dir",
            {{"path", web_dir.string()}, {"found", std::filesystem::exists(web_dir / "index.html")}});
  router.AddRoute("GET", "/", [web_dir](const HttpRequest& request) { return Static(web_dir, request); });
}

}  // namespace server
