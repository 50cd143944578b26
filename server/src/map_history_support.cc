#include "map_history_support.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>

#include "analyzer/map_comparison.h"
#include "analyzer/map_metadata.h"
#include "analyzer/map_repair.h"
#include "analyzer/telemetry_codec.h"
#include "server/analysis.h"

namespace server::map_history_internal {

storage::Result<fleet::v1::MapSnapshot> LoadSnapshot(storage::Repository& repository,
                                                     const std::string& snapshot_id) {
  ASSIGN_OR_RETURN(auto stored, repository.GetSnapshot(snapshot_id));
  fleet::v1::MapSnapshot snapshot;
  if (!snapshot.ParseFromString(stored.bytes))
    return storage::DataLoss("snapshot " + snapshot_id + " does not parse");
  return snapshot;
}

storage::Result<slamcore::Map> LoadMap(storage::Repository& repository, const std::string& snapshot_id) {
  ASSIGN_OR_RETURN(auto snapshot, LoadSnapshot(repository, snapshot_id));
  auto map = analyzer::FromProto(snapshot, "snapshot " + snapshot_id);
  if (!map.ok()) return storage::DataLoss(map.status().message());
  return std::move(map).value();
}

storage::Result<slamcore::Map> LoadRunParent(storage::Repository& repository, const storage::RunKey& key) {
  if (key.run_id.empty()) return slamcore::Map{};
  ASSIGN_OR_RETURN(auto run, repository.GetRun(key));
  if (!run.parent_snapshot_id) return slamcore::Map{};
  return LoadMap(repository, *run.parent_snapshot_id);
}

storage::Result<RunContext> LoadRunContext(storage::Repository& repository, const storage::RunKey& key,
                                           const std::string& parameter_set) {
  RunContext context;
  const std::string& run_id = key.run_id;
  if (run_id.empty()) return context;
  ASSIGN_OR_RETURN(auto parent, LoadRunParent(repository, key));
  context.parent = std::move(parent);
  auto report = repository.GetReport(key, parameter_set);
  if (report.ok()) {
    fleet::v1::RunReport parsed;
    if (!parsed.ParseFromString(report->report))
      return storage::DataLoss("report of run " + run_id + " does not parse");
    context.report = std::move(parsed);
  } else if (report.status().code() != storage::StatusCode::kNotFound) {
    return report.status();
  }
  return context;
}

std::vector<fleet::v1::MapFinding> Findings(const slamcore::Map& map, const RunContext& context) {
  return analyzer::FindMapFindings(
      {.map = &map, .run_parent = &context.parent, .report = context.report ? &*context.report : nullptr});
}

storage::Result<std::vector<storage::MapFindingRecord>> ToRecords(
    const std::vector<fleet::v1::MapFinding>& findings) {
  std::vector<storage::MapFindingRecord> records;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  for (const fleet::v1::MapFinding& finding : findings) {
    const std::string name = "finding " + std::to_string(finding.finding_id());
    auto kind = FromProto(finding.finding_kind(), name + " finding_kind");
    auto state = FromProto(finding.finding_state(), name + " finding_state");
    if (!kind.ok()) return storage::Internal(kind.status().message());
    if (!state.ok()) return storage::Internal(state.status().message());
    storage::MapFindingRecord& record = records.emplace_back();
    record.finding_id = finding.finding_id();
    record.kind = *kind;
    record.severity = finding.severity();
    record.summary = finding.summary();
    record.state = *state;
    fleet::v1::MapFinding rest = finding;
    rest.clear_finding_kind();
    rest.clear_finding_state();
    (void)google::protobuf::util::MessageToJsonString(rest, &record.detail_json, options);
  }
  return records;
}

storage::Result<std::vector<fleet::v1::MapFinding>> FromRecords(
    const std::vector<storage::MapFindingRecord>& records) {
  std::vector<fleet::v1::MapFinding> findings;
  // Findings stored before kind and state were enums spell them as strings in their JSON: the columns say.
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = true;
  for (const storage::MapFindingRecord& record : records) {
    fleet::v1::MapFinding& finding = findings.emplace_back();
    if (!google::protobuf::util::JsonStringToMessage(record.detail_json, &finding, options).ok()) {
      return storage::DataLoss("finding " + std::to_string(record.finding_id) + " does not parse");
    }
    finding.set_finding_kind(ToProto(record.kind));
    finding.set_finding_state(ToProto(record.state));
  }
  return findings;
}

std::string ActionText(const std::optional<storage::MapAction>& action) {
  return action ? std::string(storage::Name(*action)) : std::string();
}

storage::Result<storage::MapVersionRecord> NewVersion(const slamcore::Map& map,
                                                      const std::string& snapshot_id, bool with_known_area) {
  const analyzer::MapFigures figures = analyzer::ComputeFigures(map);
  storage::MapVersionRecord record;
  record.snapshot_id = snapshot_id;
  record.nodes = figures.nodes;
  record.edges = figures.edges;
  record.observation_edges = figures.observation_edges;
  record.views = figures.views;
  record.components = figures.components;
  record.chi2 = figures.chi2;
  if (with_known_area) {
    ASSIGN_OR_RETURN(auto area, analyzer::KnownArea(map));
    record.known_area_m2 = area;
  }
  return record;
}

std::int64_t NowMillis() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

const storage::MapVersionRecord* Current(const std::vector<storage::MapVersionRecord>& versions) {
  for (auto it = versions.rbegin(); it != versions.rend(); ++it) {
    if (it->approval == storage::MapApproval::kApproved) return &*it;
  }
  return nullptr;
}

const storage::MapVersionRecord* Head(const std::vector<storage::MapVersionRecord>& versions) {
  for (auto it = versions.rbegin(); it != versions.rend(); ++it) {
    if (it->approval == storage::MapApproval::kApproved || it->approval == storage::MapApproval::kPending)
      return &*it;
  }
  return nullptr;
}

const storage::MapVersionRecord* FindRecord(const std::vector<storage::MapVersionRecord>& versions,
                                            std::int64_t version) {
  for (const storage::MapVersionRecord& record : versions) {
    if (record.version == version) return &record;
  }
  return nullptr;
}

const storage::MapVersionRecord* ComparisonReference(const std::vector<storage::MapVersionRecord>& versions,
                                                     const storage::MapVersionRecord& record) {
  const storage::MapVersionRecord* at = &record;
  while (at != nullptr && at->origin != storage::MapOrigin::kImport) {
    if (!at->parent_version) return nullptr;
    at = FindRecord(versions, *at->parent_version);
  }
  if (at == nullptr || !at->parent_version) return nullptr;
  return FindRecord(versions, *at->parent_version);
}

bool IsBuiltOn(const std::vector<storage::MapVersionRecord>& versions,
               const storage::MapVersionRecord& record, std::int64_t ancestor) {
  for (const storage::MapVersionRecord* at = &record; at != nullptr;
       at = at->parent_version ? FindRecord(versions, *at->parent_version) : nullptr) {
    if (at->version == ancestor) return true;
  }
  return false;
}

std::vector<fleet::v1::MapFinding> MergeFindings(std::vector<fleet::v1::MapFinding> first,
                                                 const std::vector<fleet::v1::MapFinding>& second) {
  first.insert(first.end(), second.begin(), second.end());
  std::stable_sort(first.begin(), first.end(),
                   [](const fleet::v1::MapFinding& a, const fleet::v1::MapFinding& b) {
                     return a.severity() > b.severity();
                   });
  for (std::size_t i = 0; i < first.size(); ++i) first[i].set_finding_id(static_cast<std::int64_t>(i) + 1);
  return first;
}

storage::Result<ComparedMap> LoadComparedMap(storage::Repository& repository,
                                             const std::string& snapshot_id) {
  ASSIGN_OR_RETURN(auto snapshot, LoadSnapshot(repository, snapshot_id));
  auto map = analyzer::FromProto(snapshot, "snapshot " + snapshot_id);
  if (!map.ok()) return storage::DataLoss(map.status().message());
  ASSIGN_OR_RETURN(auto grid, analyzer::RenderHomeGrid(*map));
  return ComparedMap{std::move(grid), analyzer::DockOf(snapshot)};
}

}  // namespace server::map_history_internal
