// What the parts of MapHistory share (map_history.cc, map_history_imports.cc): loading stored maps and
// snapshots, findings to and from their records, new version records, and questions asked of a robot's
// version list. Private to server/src.
//
// Thread safety: free functions; the repository they are given is thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "server/map_history.h"
#include "slamcore/occupancy_grid.h"
#include "slamcore/se2.h"

namespace server::map_history_internal {

storage::Result<fleet::v1::MapSnapshot> LoadSnapshot(storage::Repository& repository,
                                                     const std::string& snapshot_id);

storage::Result<slamcore::Map> LoadMap(storage::Repository& repository, const std::string& snapshot_id);

/// What findings compare a version with: the map before the version's run, and the server's rerun of it.
struct RunContext {
  slamcore::Map parent;  // empty for a robot's first run
  std::optional<fleet::v1::RunReport> report;
};

/// The map the run started from; empty for a robot's first run (or a version without a run).
storage::Result<slamcore::Map> LoadRunParent(storage::Repository& repository, const storage::RunKey& key);

storage::Result<RunContext> LoadRunContext(storage::Repository& repository, const storage::RunKey& key,
                                           const std::string& parameter_set);

std::vector<fleet::v1::MapFinding> Findings(const slamcore::Map& map, const RunContext& context);

/// The records of findings the analysis made; INTERNAL for a finding without a kind or state (a bug there).
/// Kind and state are the records' columns, so the JSON of the rest leaves them out.
storage::Result<std::vector<storage::MapFindingRecord>> ToRecords(
    const std::vector<fleet::v1::MapFinding>& findings);

storage::Result<std::vector<fleet::v1::MapFinding>> FromRecords(
    const std::vector<storage::MapFindingRecord>& records);

/// "" for a version without an action (uploads).
std::string ActionText(const std::optional<storage::MapAction>& action);

/// A new version's record with its map's figures. The known area needs a rendering: uploads leave it to
/// the run's analysis (OnRunAnalysed) to keep ingest fast.
storage::Result<storage::MapVersionRecord> NewVersion(const slamcore::Map& map,
                                                      const std::string& snapshot_id, bool with_known_area);

std::int64_t NowMillis();

const storage::MapVersionRecord* Current(const std::vector<storage::MapVersionRecord>& versions);

/// What repairs continue: the newest approved or pending version (rejected and stale ones are side branches).
const storage::MapVersionRecord* Head(const std::vector<storage::MapVersionRecord>& versions);

/// `version` among `versions`, or null.
const storage::MapVersionRecord* FindRecord(const std::vector<storage::MapVersionRecord>& versions,
                                            std::int64_t version);

/// What a map-only version is compared with: the version before the import its chain started from (parents
/// are followed through repairs back to the import). Null when that import was the robot's first version.
const storage::MapVersionRecord* ComparisonReference(const std::vector<storage::MapVersionRecord>& versions,
                                                     const storage::MapVersionRecord& record);

/// Whether `record` is `ancestor` or built on it, following parents.
bool IsBuiltOn(const std::vector<storage::MapVersionRecord>& versions,
               const storage::MapVersionRecord& record, std::int64_t ancestor);

/// Both lists in one, by severity (highest first) and numbered from 1 again.
std::vector<fleet::v1::MapFinding> MergeFindings(std::vector<fleet::v1::MapFinding> first,
                                                 const std::vector<fleet::v1::MapFinding>& second);

/// The previous map of a comparison: its grid and its dock.
struct ComparedMap {
  slamcore::OccupancyGrid grid;
  std::optional<slamcore::SE2> dock;
};

storage::Result<ComparedMap> LoadComparedMap(storage::Repository& repository, const std::string& snapshot_id);

}  // namespace server::map_history_internal
