// The dashboard's JSON for storage records and query answers (the /api routes' bodies). Internal to server/.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "server/fleet_queries.h"
#include "storage/records.h"

namespace server::dashboard_json {

/// null for an absent value (a share without a denominator).
nlohmann::json Optional(const std::optional<double>& value);
/// The counters and the paper's figures derived from them (null when the denominator is 0).
nlohmann::json FiguresJson(const Figures& figures);
/// FiguresJson of each group with its "key".
nlohmann::json GroupsJson(const std::vector<FiguresGroup>& groups);
nlohmann::json RunJson(const storage::RunRecord& run);
nlohmann::json ReportCountersJson(const storage::ReportRecord& report);
nlohmann::json RegionJson(const storage::ProtrusionRegionRecord& region);
/// With the payload's parameter set and filter or run, when it parses.
nlohmann::json JobJson(const storage::JobRecord& job);

}  // namespace server::dashboard_json
