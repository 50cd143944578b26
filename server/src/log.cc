#include "server/log.h"

#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <cstdio>

namespace server::log {
namespace {

std::atomic<bool> g_json{true};

std::string JsonString(std::string_view value) {
  std::string out = "\"";
  for (char c : value) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof buffer, "\\u%04x", c);
          out += buffer;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::shared_ptr<spdlog::logger> Logger() {
  static std::shared_ptr<spdlog::logger> logger = [] {
    auto made = spdlog::stderr_logger_mt("fleetd");
    made->set_pattern("%v");
    made->flush_on(spdlog::level::info);
    return made;
  }();
  return logger;
}

const char* LevelName(Level level) {
  switch (level) {
    case Level::kDebug: return "debug";
    case Level::kInfo: return "info";
    case Level::kWarn: return "warn";
    case Level::kError: return "error";
  }
  return "info";
}

}  // namespace

void Configure(const std::string& level, const std::string& format) {
  g_json = format != "text";
  Logger()->set_level(spdlog::level::from_str(level == "warn" ? "warning" : level));
  // Timestamps are ours (ISO 8601 UTC); spdlog prints the line as given.
  Logger()->set_pattern(g_json ? "{\"ts\":\"%Y-%m-%dT%H:%M:%S.%eZ\",%v}" : "%Y-%m-%dT%H:%M:%S.%eZ %v",
                        spdlog::pattern_time_type::utc);
}

Field::Field(std::string_view k, std::string_view value)
    : key(k),
      json(JsonString(value)),
      text(value.find(' ') == std::string_view::npos && !value.empty() ? std::string(value)
                                                                       : JsonString(value)) {}
Field::Field(std::string_view k, long long value) : key(k), json(std::to_string(value)), text(json) {}
Field::Field(std::string_view k, double value) : key(k) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", value);
  json = text = buffer;
}
Field::Field(std::string_view k, bool value) : key(k), json(value ? "true" : "false"), text(json) {}

void Write(Level level, std::string_view event, std::initializer_list<Field> fields) {
  static const spdlog::level::level_enum kLevels[] = {spdlog::level::debug, spdlog::level::info,
                                                      spdlog::level::warn, spdlog::level::err};
  const auto spd_level = kLevels[static_cast<int>(level)];
  auto logger = Logger();
  if (!logger->should_log(spd_level)) return;
  std::string line;
  if (g_json) {
    line = "\"level\":\"" + std::string(LevelName(level)) + "\",\"event\":" + JsonString(event);
    for (const Field& field : fields) line += "," + JsonString(field.key) + ":" + field.json;
  } else {
    line = std::string(LevelName(level)) + " event=" + std::string(event);
    for (const Field& field : fields) line += " " + field.key + "=" + field.text;
  }
  logger->log(spd_level, "{}", line);
}

}  // namespace server::log
