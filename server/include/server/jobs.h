// The jobs fleetd puts on storage's queue, and their payloads (small JSON objects, documented in
// docs/formats/service.md):
//   "analyze_run": {"robot_id": "...", "run_id": "...", "parameter_set": "..."}  one run with one parameter
//                  set (jobs queued before run ids were per robot have no robot_id: found by run id alone)
//   "reprocess":   {"parameter_set": "...", "filter": {...}}   a parent job fanning out analyze_run children
//
// Thread safety: free functions without shared state.
#pragma once

#include <string>

#include "storage/records.h"
#include "storage/status.h"

namespace server {

inline constexpr const char* kAnalyzeRunJob = "analyze_run";
inline constexpr const char* kReprocessJob = "reprocess";

struct AnalyzePayload {
  std::string robot_id;
  std::string run_id;
  std::string parameter_set;
};
std::string EncodeAnalyzePayload(const AnalyzePayload& payload);
storage::Result<AnalyzePayload> DecodeAnalyzePayload(const std::string& json);

struct ReprocessPayload {
  std::string parameter_set;
  storage::RunFilter filter;
};
std::string EncodeReprocessPayload(const ReprocessPayload& payload);
storage::Result<ReprocessPayload> DecodeReprocessPayload(const std::string& json);

}  // namespace server
