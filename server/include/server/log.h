// Structured logs: one JSON object per line on stderr (stdout's first line belongs to the bound addresses),
// e.g. {"ts":"2026-01-01T00:00:00.123Z","level":"info","event":"run_stored","run_id":"r1","events":512}.
// Backed by spdlog, which stays inside log.cc.
//
// Thread safety: every function is safe from any thread.
#pragma once

#include <initializer_list>
#include <string>
#include <string_view>
#include <utility>

namespace server::log {

enum class Level { kDebug, kInfo, kWarn, kError };

/// level: "debug", "info", "warn", "error"; format: "json" or "text" (key=value). Call once, early.
void Configure(const std::string& level, const std::string& format);

/// A field value, already rendered: strings are quoted and escaped, numbers are not.
struct Field {
  Field(std::string_view name, std::string_view value);
  Field(std::string_view name, const std::string& value) : Field(name, std::string_view(value)) {}
  Field(std::string_view name, const char* value) : Field(name, std::string_view(value)) {}
  Field(std::string_view name, long long value);
  Field(std::string_view name, long value) : Field(name, static_cast<long long>(value)) {}
  Field(std::string_view name, int value) : Field(name, static_cast<long long>(value)) {}
  Field(std::string_view name, unsigned long value) : Field(name, static_cast<long long>(value)) {}
  Field(std::string_view name, double value);
  Field(std::string_view name, bool value);
  std::string key, json, text;
};

void Write(Level level, std::string_view event, std::initializer_list<Field> fields = {});
inline void Info(std::string_view event, std::initializer_list<Field> fields = {}) {
  Write(Level::kInfo, event, fields);
}
inline void Warn(std::string_view event, std::initializer_list<Field> fields = {}) {
  Write(Level::kWarn, event, fields);
}
inline void Error(std::string_view event, std::initializer_list<Field> fields = {}) {
  Write(Level::kError, event, fields);
}
inline void Debug(std::string_view event, std::initializer_list<Field> fields = {}) {
  Write(Level::kDebug, event, fields);
}

}  // namespace server::log
