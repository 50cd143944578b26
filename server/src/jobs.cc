#include "server/jobs.h"

#include <nlohmann/json.hpp>

namespace server {

std::string EncodeAnalyzePayload(const AnalyzePayload& payload) {
  return nlohmann::json{
      {"robot_id", payload.robot_id}, {"run_id", payload.run_id}, {"parameter_set", payload.parameter_set}}
      .dump();
}

storage::Result<AnalyzePayload> DecodeAnalyzePayload(const std::string& json) {
  try {
    const auto parsed = nlohmann::json::parse(json);
    AnalyzePayload payload;
    payload.robot_id = parsed.value("robot_id", "");
    payload.run_id = parsed.at("run_id").get<std::string>();
    payload.parameter_set = parsed.at("parameter_set").get<std::string>();
    return payload;
  } catch (const std::exception& e) {
    return storage::InvalidArgument(std::string("analyze_run payload: ") + e.what());
  }
}

std::string EncodeReprocessPayload(const ReprocessPayload& payload) {
  nlohmann::json filter = {{"robot_id", payload.filter.robot_id},
                           {"firmware", payload.filter.firmware},
                           {"robot_model", payload.filter.robot_model},
                           {"parameter_set", payload.filter.parameter_set}};
  if (payload.filter.started_from_ms) filter["started_from_ms"] = *payload.filter.started_from_ms;
  if (payload.filter.started_before_ms) filter["started_before_ms"] = *payload.filter.started_before_ms;
  return nlohmann::json{{"parameter_set", payload.parameter_set}, {"filter", filter}}.dump();
}

storage::Result<ReprocessPayload> DecodeReprocessPayload(const std::string& json) {
  try {
    const auto parsed = nlohmann::json::parse(json);
    ReprocessPayload payload;
    payload.parameter_set = parsed.at("parameter_set").get<std::string>();
    const auto& filter = parsed.at("filter");
    payload.filter.robot_id = filter.value("robot_id", "");
    payload.filter.firmware = filter.value("firmware", "");
    payload.filter.robot_model = filter.value("robot_model", "");
    payload.filter.parameter_set = filter.value("parameter_set", "");
    if (filter.contains("started_from_ms"))
      payload.filter.started_from_ms = filter["started_from_ms"].get<std::int64_t>();
    if (filter.contains("started_before_ms")) {
      payload.filter.started_before_ms = filter["started_before_ms"].get<std::int64_t>();
    }
    return payload;
  } catch (const std::exception& e) {
    return storage::InvalidArgument(std::string("reprocess payload: ") + e.what());
  }
}

}  // namespace server
