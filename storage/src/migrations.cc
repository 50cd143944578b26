#include "migrations.h"

#include <chrono>
#include <string>
#include <vector>

namespace storage::internal {
namespace {

// Each entry is migration N+1. The SQL is written once for both back-ends; the tokens below expand to each
// dialect's spelling. Never edit a shipped migration: append a new one.
//   ${BLOB} binary column     ${ID} auto-increment 64-bit primary key
const std::vector<std::string>& Migrations() {
  static const std::vector<std::string> kMigrations = {
      // 1: the initial schema.
      R"sql(
CREATE TABLE robots (
  robot_id TEXT PRIMARY KEY,
  robot_model TEXT NOT NULL,
  firmware TEXT NOT NULL,
  registered_at_ms BIGINT NOT NULL
);
CREATE TABLE credentials (
  principal TEXT PRIMARY KEY,
  algorithm TEXT NOT NULL,
  iterations BIGINT NOT NULL,
  salt ${BLOB} NOT NULL,
  hash ${BLOB} NOT NULL,
  updated_at_ms BIGINT NOT NULL
);
CREATE TABLE snapshots (
  snapshot_id TEXT PRIMARY KEY,
  data ${BLOB} NOT NULL,
  data_crc32 BIGINT NOT NULL,
  data_size BIGINT NOT NULL,
  created_at_ms BIGINT NOT NULL
);
CREATE TABLE runs (
  run_id TEXT PRIMARY KEY,
  robot_id TEXT NOT NULL REFERENCES robots(robot_id),
  firmware TEXT NOT NULL,
  robot_model TEXT NOT NULL,
  started_at_ms BIGINT NOT NULL,
  ended_at_ms BIGINT NOT NULL,
  parent_snapshot_id TEXT REFERENCES snapshots(snapshot_id),
  child_snapshot_id TEXT REFERENCES snapshots(snapshot_id),
  telemetry ${BLOB} NOT NULL,
  telemetry_crc32 BIGINT NOT NULL,
  telemetry_size BIGINT NOT NULL,
  payload_sha256 TEXT NOT NULL,
  uploaded_at_ms BIGINT NOT NULL
);
CREATE INDEX runs_by_start ON runs (started_at_ms, run_id);
CREATE INDEX runs_by_robot ON runs (robot_id, started_at_ms);
CREATE INDEX runs_by_firmware ON runs (firmware, started_at_ms);
CREATE TABLE parameter_sets (
  name TEXT PRIMARY KEY,
  data ${BLOB} NOT NULL,
  data_crc32 BIGINT NOT NULL,
  data_size BIGINT NOT NULL,
  data_sha256 TEXT NOT NULL,
  created_at_ms BIGINT NOT NULL
);
CREATE TABLE reports (
  run_id TEXT NOT NULL REFERENCES runs(run_id),
  parameter_set TEXT NOT NULL REFERENCES parameter_sets(name),
  recovery_created BIGINT NOT NULL,
  recovery_accepted BIGINT NOT NULL,
  merge_created BIGINT NOT NULL,
  merge_conditionally_accepted BIGINT NOT NULL,
  merge_conditional_then_rejected BIGINT NOT NULL,
  views_total BIGINT NOT NULL,
  views_ambiguous BIGINT NOT NULL,
  started_localized BIGINT NOT NULL,
  protrusions_found BIGINT NOT NULL,
  data ${BLOB} NOT NULL,
  data_crc32 BIGINT NOT NULL,
  data_size BIGINT NOT NULL,
  created_at_ms BIGINT NOT NULL,
  PRIMARY KEY (run_id, parameter_set)
);
CREATE INDEX reports_by_parameter_set ON reports (parameter_set, run_id);
CREATE TABLE decisions (
  run_id TEXT NOT NULL,
  parameter_set TEXT NOT NULL,
  sequence BIGINT NOT NULL,
  time_s DOUBLE PRECISION NOT NULL,
  kind TEXT NOT NULL,
  outcome TEXT NOT NULL,
  subject_id BIGINT NOT NULL,
  score DOUBLE PRECISION NOT NULL,
  detail TEXT NOT NULL,
  PRIMARY KEY (run_id, parameter_set, sequence),
  FOREIGN KEY (run_id, parameter_set) REFERENCES reports(run_id, parameter_set) ON DELETE CASCADE
);
CREATE TABLE ambiguous_views (
  run_id TEXT NOT NULL,
  parameter_set TEXT NOT NULL,
  view_id BIGINT NOT NULL,
  time_s DOUBLE PRECISION NOT NULL,
  candidate_count BIGINT NOT NULL,
  ambiguity DOUBLE PRECISION NOT NULL,
  detail TEXT NOT NULL,
  PRIMARY KEY (run_id, parameter_set, view_id),
  FOREIGN KEY (run_id, parameter_set) REFERENCES reports(run_id, parameter_set) ON DELETE CASCADE
);
CREATE TABLE protrusion_regions (
  run_id TEXT NOT NULL,
  parameter_set TEXT NOT NULL,
  region_id BIGINT NOT NULL,
  min_x DOUBLE PRECISION NOT NULL,
  min_y DOUBLE PRECISION NOT NULL,
  max_x DOUBLE PRECISION NOT NULL,
  max_y DOUBLE PRECISION NOT NULL,
  features_json TEXT NOT NULL,
  predicted_class TEXT NOT NULL,
  probability DOUBLE PRECISION NOT NULL,
  label TEXT,
  labelled_by TEXT,
  PRIMARY KEY (run_id, parameter_set, region_id),
  FOREIGN KEY (run_id, parameter_set) REFERENCES reports(run_id, parameter_set) ON DELETE CASCADE
);
CREATE INDEX labelled_regions ON protrusion_regions (parameter_set, label);
CREATE TABLE models (
  name TEXT NOT NULL,
  version BIGINT NOT NULL,
  data ${BLOB} NOT NULL,
  data_crc32 BIGINT NOT NULL,
  data_size BIGINT NOT NULL,
  data_sha256 TEXT NOT NULL,
  active BIGINT NOT NULL,
  created_at_ms BIGINT NOT NULL,
  PRIMARY KEY (name, version)
);
CREATE TABLE jobs (
  job_id ${ID},
  kind TEXT NOT NULL,
  payload ${BLOB} NOT NULL,
  state TEXT NOT NULL,
  attempts BIGINT NOT NULL,
  max_attempts BIGINT NOT NULL,
  parent_job_id BIGINT REFERENCES jobs(job_id),
  lease_owner TEXT,
  lease_token TEXT,
  lease_expires_at_ms BIGINT,
  last_error TEXT NOT NULL,
  progress_done BIGINT NOT NULL,
  progress_total BIGINT NOT NULL,
  created_at_ms BIGINT NOT NULL,
  updated_at_ms BIGINT NOT NULL
);
CREATE INDEX jobs_by_state ON jobs (state, job_id);
CREATE INDEX jobs_by_parent ON jobs (parent_job_id);
)sql",
      // 2: map history per robot, with findings.
      R"sql(
CREATE TABLE map_versions (
  robot_id TEXT NOT NULL REFERENCES robots(robot_id),
  version BIGINT NOT NULL,
  parent_version BIGINT,
  snapshot_id TEXT NOT NULL REFERENCES snapshots(snapshot_id),
  origin TEXT NOT NULL,
  run_id TEXT,
  action TEXT NOT NULL,
  action_detail TEXT NOT NULL,
  created_by TEXT NOT NULL,
  reason TEXT NOT NULL,
  created_at_ms BIGINT NOT NULL,
  approval TEXT NOT NULL,
  approved_by TEXT NOT NULL,
  approved_at_ms BIGINT NOT NULL,
  nodes BIGINT NOT NULL,
  edges BIGINT NOT NULL,
  observation_edges BIGINT NOT NULL,
  views BIGINT NOT NULL,
  components BIGINT NOT NULL,
  known_area_m2 DOUBLE PRECISION NOT NULL,
  chi2 DOUBLE PRECISION NOT NULL,
  open_findings BIGINT NOT NULL,
  PRIMARY KEY (robot_id, version)
);
CREATE UNIQUE INDEX map_versions_by_upload ON map_versions (run_id) WHERE origin = 'upload';
CREATE TABLE map_findings (
  robot_id TEXT NOT NULL,
  version BIGINT NOT NULL,
  finding_id BIGINT NOT NULL,
  kind TEXT NOT NULL,
  severity DOUBLE PRECISION NOT NULL,
  summary TEXT NOT NULL,
  state TEXT NOT NULL,
  detail_json TEXT NOT NULL,
  PRIMARY KEY (robot_id, version, finding_id),
  FOREIGN KEY (robot_id, version) REFERENCES map_versions(robot_id, version)
);
)sql",
      // 3: accepted recovery hypotheses that the Mapper later retracted (correlated wrong observations).
      R"sql(
ALTER TABLE reports ADD COLUMN recovery_retracted BIGINT NOT NULL DEFAULT 0;
)sql",
      // 4: a run is (robot_id, run_id), so one robot can never take another's run id; runs whose events
      // retention pruned; jobs name the robot they work for (erasure); the audit log. The run tables are
      // rebuilt under new names, the old ones dropped children first, then the new ones renamed (both
      // databases carry foreign keys across a rename).
      R"sql(
CREATE TABLE runs_v4 (
  robot_id TEXT NOT NULL REFERENCES robots(robot_id),
  run_id TEXT NOT NULL,
  firmware TEXT NOT NULL,
  robot_model TEXT NOT NULL,
  started_at_ms BIGINT NOT NULL,
  ended_at_ms BIGINT NOT NULL,
  parent_snapshot_id TEXT REFERENCES snapshots(snapshot_id),
  child_snapshot_id TEXT REFERENCES snapshots(snapshot_id),
  telemetry ${BLOB} NOT NULL,
  telemetry_crc32 BIGINT NOT NULL,
  telemetry_size BIGINT NOT NULL,
  payload_sha256 TEXT NOT NULL,
  uploaded_at_ms BIGINT NOT NULL,
  telemetry_pruned_at_ms BIGINT,
  PRIMARY KEY (robot_id, run_id)
);
INSERT INTO runs_v4 (robot_id, run_id, firmware, robot_model, started_at_ms, ended_at_ms, parent_snapshot_id,
  child_snapshot_id, telemetry, telemetry_crc32, telemetry_size, payload_sha256, uploaded_at_ms)
  SELECT robot_id, run_id, firmware, robot_model, started_at_ms, ended_at_ms, parent_snapshot_id,
  child_snapshot_id, telemetry, telemetry_crc32, telemetry_size, payload_sha256, uploaded_at_ms FROM runs;
CREATE TABLE reports_v4 (
  robot_id TEXT NOT NULL,
  run_id TEXT NOT NULL,
  parameter_set TEXT NOT NULL REFERENCES parameter_sets(name),
  recovery_created BIGINT NOT NULL,
  recovery_accepted BIGINT NOT NULL,
  recovery_retracted BIGINT NOT NULL DEFAULT 0,
  merge_created BIGINT NOT NULL,
  merge_conditionally_accepted BIGINT NOT NULL,
  merge_conditional_then_rejected BIGINT NOT NULL,
  views_total BIGINT NOT NULL,
  views_ambiguous BIGINT NOT NULL,
  started_localized BIGINT NOT NULL,
  protrusions_found BIGINT NOT NULL,
  data ${BLOB} NOT NULL,
  data_crc32 BIGINT NOT NULL,
  data_size BIGINT NOT NULL,
  created_at_ms BIGINT NOT NULL,
  PRIMARY KEY (robot_id, run_id, parameter_set),
  FOREIGN KEY (robot_id, run_id) REFERENCES runs_v4(robot_id, run_id)
);
INSERT INTO reports_v4 (robot_id, run_id, parameter_set, recovery_created, recovery_accepted, recovery_retracted,
  merge_created, merge_conditionally_accepted, merge_conditional_then_rejected, views_total, views_ambiguous,
  started_localized, protrusions_found, data, data_crc32, data_size, created_at_ms)
  SELECT r.robot_id, p.run_id, p.parameter_set, p.recovery_created, p.recovery_accepted, p.recovery_retracted,
  p.merge_created, p.merge_conditionally_accepted, p.merge_conditional_then_rejected, p.views_total,
  p.views_ambiguous, p.started_localized, p.protrusions_found, p.data, p.data_crc32, p.data_size, p.created_at_ms
  FROM reports p JOIN runs r ON r.run_id = p.run_id;
CREATE TABLE decisions_v4 (
  robot_id TEXT NOT NULL,
  run_id TEXT NOT NULL,
  parameter_set TEXT NOT NULL,
  sequence BIGINT NOT NULL,
  time_s DOUBLE PRECISION NOT NULL,
  kind TEXT NOT NULL,
  outcome TEXT NOT NULL,
  subject_id BIGINT NOT NULL,
  score DOUBLE PRECISION NOT NULL,
  detail TEXT NOT NULL,
  PRIMARY KEY (robot_id, run_id, parameter_set, sequence),
  FOREIGN KEY (robot_id, run_id, parameter_set) REFERENCES reports_v4(robot_id, run_id, parameter_set) ON DELETE CASCADE
);
INSERT INTO decisions_v4 SELECT r.robot_id, d.run_id, d.parameter_set, d.sequence, d.time_s, d.kind, d.outcome,
  d.subject_id, d.score, d.detail FROM decisions d JOIN runs r ON r.run_id = d.run_id;
CREATE TABLE ambiguous_views_v4 (
  robot_id TEXT NOT NULL,
  run_id TEXT NOT NULL,
  parameter_set TEXT NOT NULL,
  view_id BIGINT NOT NULL,
  time_s DOUBLE PRECISION NOT NULL,
  candidate_count BIGINT NOT NULL,
  ambiguity DOUBLE PRECISION NOT NULL,
  detail TEXT NOT NULL,
  PRIMARY KEY (robot_id, run_id, parameter_set, view_id),
  FOREIGN KEY (robot_id, run_id, parameter_set) REFERENCES reports_v4(robot_id, run_id, parameter_set) ON DELETE CASCADE
);
INSERT INTO ambiguous_views_v4 SELECT r.robot_id, a.run_id, a.parameter_set, a.view_id, a.time_s,
  a.candidate_count, a.ambiguity, a.detail FROM ambiguous_views a JOIN runs r ON r.run_id = a.run_id;
CREATE TABLE protrusion_regions_v4 (
  robot_id TEXT NOT NULL,
  run_id TEXT NOT NULL,
  parameter_set TEXT NOT NULL,
  region_id BIGINT NOT NULL,
  min_x DOUBLE PRECISION NOT NULL,
  min_y DOUBLE PRECISION NOT NULL,
  max_x DOUBLE PRECISION NOT NULL,
  max_y DOUBLE PRECISION NOT NULL,
  features_json TEXT NOT NULL,
  predicted_class TEXT NOT NULL,
  probability DOUBLE PRECISION NOT NULL,
  label TEXT,
  labelled_by TEXT,
  PRIMARY KEY (robot_id, run_id, parameter_set, region_id),
  FOREIGN KEY (robot_id, run_id, parameter_set) REFERENCES reports_v4(robot_id, run_id, parameter_set) ON DELETE CASCADE
);
INSERT INTO protrusion_regions_v4 SELECT r.robot_id, g.run_id, g.parameter_set, g.region_id, g.min_x, g.min_y,
  g.max_x, g.max_y, g.features_json, g.predicted_class, g.probability, g.label, g.labelled_by
  FROM protrusion_regions g JOIN runs r ON r.run_id = g.run_id;
DROP TABLE decisions;
DROP TABLE ambiguous_views;
DROP TABLE protrusion_regions;
DROP TABLE reports;
DROP TABLE runs;
ALTER TABLE runs_v4 RENAME TO runs;
ALTER TABLE reports_v4 RENAME TO reports;
ALTER TABLE decisions_v4 RENAME TO decisions;
ALTER TABLE ambiguous_views_v4 RENAME TO ambiguous_views;
ALTER TABLE protrusion_regions_v4 RENAME TO protrusion_regions;
CREATE INDEX runs_by_start ON runs (started_at_ms, run_id, robot_id);
CREATE INDEX runs_by_robot ON runs (robot_id, started_at_ms);
CREATE INDEX runs_by_firmware ON runs (firmware, started_at_ms);
CREATE INDEX runs_by_upload ON runs (uploaded_at_ms);
CREATE INDEX runs_by_run_id ON runs (run_id);
CREATE INDEX reports_by_parameter_set ON reports (parameter_set, robot_id, run_id);
CREATE INDEX labelled_regions ON protrusion_regions (parameter_set, label);
DROP INDEX map_versions_by_upload;
CREATE UNIQUE INDEX map_versions_by_upload ON map_versions (robot_id, run_id) WHERE origin = 'upload';
ALTER TABLE jobs ADD COLUMN robot_id TEXT;
CREATE INDEX jobs_by_robot ON jobs (robot_id);
CREATE INDEX jobs_by_finish ON jobs (state, updated_at_ms);
CREATE TABLE audit_log (
  entry_id ${ID},
  at_ms BIGINT NOT NULL,
  actor TEXT NOT NULL,
  action TEXT NOT NULL,
  subject TEXT NOT NULL,
  detail_json TEXT NOT NULL
);
)sql",
      // 5: what an imported map said besides its grid (rooms, path, poses, virtual walls, zones), per version.
      R"sql(
CREATE TABLE map_metadata (
  robot_id TEXT NOT NULL,
  version BIGINT NOT NULL,
  data ${BLOB} NOT NULL,
  data_crc32 BIGINT NOT NULL,
  data_size BIGINT NOT NULL,
  PRIMARY KEY (robot_id, version),
  FOREIGN KEY (robot_id, version) REFERENCES map_versions(robot_id, version) ON DELETE CASCADE
);
)sql",
      // 6: credential revocation seen by every process (epochs), and the health probe's write.
      R"sql(
ALTER TABLE credentials ADD COLUMN epoch BIGINT NOT NULL DEFAULT 0;
CREATE INDEX credentials_by_epoch ON credentials (epoch);
CREATE TABLE credential_epoch (
  singleton BIGINT PRIMARY KEY,
  epoch BIGINT NOT NULL
);
INSERT INTO credential_epoch (singleton, epoch) VALUES (1, 0);
CREATE TABLE health_probe (
  singleton BIGINT PRIMARY KEY,
  prober TEXT NOT NULL,
  probed_at_ms BIGINT NOT NULL
);
)sql",
      // 7: the statistics roll-up, kept by every report write, so fleet statistics cost the same at 500,000
      // runs as at 5,000 (sql_repository_rollup.cc); filled here from the reports already stored.
      R"sql(
CREATE TABLE report_rollup (
  parameter_set TEXT NOT NULL,
  day BIGINT NOT NULL,
  firmware TEXT NOT NULL,
  robot_model TEXT NOT NULL,
  reports BIGINT NOT NULL,
  recovery_created BIGINT NOT NULL,
  recovery_accepted BIGINT NOT NULL,
  merge_created BIGINT NOT NULL,
  merge_conditionally_accepted BIGINT NOT NULL,
  merge_conditional_then_rejected BIGINT NOT NULL,
  views_total BIGINT NOT NULL,
  views_ambiguous BIGINT NOT NULL,
  started_localized BIGINT NOT NULL,
  protrusions_found BIGINT NOT NULL,
  recovery_retracted BIGINT NOT NULL,
  PRIMARY KEY (parameter_set, day, firmware, robot_model)
);
CREATE TABLE report_robot_rollup (
  parameter_set TEXT NOT NULL,
  robot_id TEXT NOT NULL,
  reports BIGINT NOT NULL,
  recovery_created BIGINT NOT NULL,
  recovery_accepted BIGINT NOT NULL,
  merge_created BIGINT NOT NULL,
  merge_conditionally_accepted BIGINT NOT NULL,
  merge_conditional_then_rejected BIGINT NOT NULL,
  views_total BIGINT NOT NULL,
  views_ambiguous BIGINT NOT NULL,
  started_localized BIGINT NOT NULL,
  protrusions_found BIGINT NOT NULL,
  recovery_retracted BIGINT NOT NULL,
  PRIMARY KEY (parameter_set, robot_id)
);
CREATE INDEX report_robot_rollup_by_robot ON report_robot_rollup (robot_id);
CREATE TABLE report_robot_presence (
  parameter_set TEXT NOT NULL,
  dimension TEXT NOT NULL,
  group_key TEXT NOT NULL,
  robot_id TEXT NOT NULL,
  reports BIGINT NOT NULL,
  PRIMARY KEY (parameter_set, dimension, group_key, robot_id)
);
CREATE INDEX report_robot_presence_by_robot ON report_robot_presence (robot_id);
CREATE TABLE report_robot_counts (
  parameter_set TEXT NOT NULL,
  dimension TEXT NOT NULL,
  group_key TEXT NOT NULL,
  robots BIGINT NOT NULL,
  PRIMARY KEY (parameter_set, dimension, group_key)
);
INSERT INTO report_rollup (parameter_set, day, firmware, robot_model, reports, recovery_created, recovery_accepted, merge_created, merge_conditionally_accepted, merge_conditional_then_rejected, views_total, views_ambiguous, started_localized, protrusions_found, recovery_retracted)
  SELECT p.parameter_set, CASE WHEN r.started_at_ms >= 0 THEN r.started_at_ms / 86400000 ELSE (r.started_at_ms - 86399999) / 86400000 END, r.firmware, r.robot_model, COUNT(*), SUM(p.recovery_created), SUM(p.recovery_accepted), SUM(p.merge_created), SUM(p.merge_conditionally_accepted), SUM(p.merge_conditional_then_rejected), SUM(p.views_total), SUM(p.views_ambiguous), SUM(p.started_localized), SUM(p.protrusions_found), SUM(p.recovery_retracted)
  FROM reports p JOIN runs r ON r.robot_id = p.robot_id AND r.run_id = p.run_id GROUP BY 1, 2, 3, 4;
INSERT INTO report_robot_rollup (parameter_set, robot_id, reports, recovery_created, recovery_accepted, merge_created, merge_conditionally_accepted, merge_conditional_then_rejected, views_total, views_ambiguous, started_localized, protrusions_found, recovery_retracted)
  SELECT p.parameter_set, p.robot_id, COUNT(*), SUM(p.recovery_created), SUM(p.recovery_accepted), SUM(p.merge_created), SUM(p.merge_conditionally_accepted), SUM(p.merge_conditional_then_rejected), SUM(p.views_total), SUM(p.views_ambiguous), SUM(p.started_localized), SUM(p.protrusions_found), SUM(p.recovery_retracted) FROM reports p GROUP BY 1, 2;
INSERT INTO report_robot_presence (parameter_set, dimension, group_key, robot_id, reports)
  SELECT g.parameter_set, g.dimension, g.group_key, g.robot_id, COUNT(*) FROM (
    SELECT p.parameter_set, d.dimension, CASE d.dimension WHEN 'day' THEN CAST(CASE WHEN r.started_at_ms >= 0 THEN r.started_at_ms / 86400000 ELSE (r.started_at_ms - 86399999) / 86400000 END AS TEXT)
      WHEN 'firmware' THEN r.firmware ELSE r.robot_model END AS group_key, p.robot_id
    FROM reports p JOIN runs r ON r.robot_id = p.robot_id AND r.run_id = p.run_id
    CROSS JOIN (SELECT 'day' AS dimension UNION ALL SELECT 'firmware' UNION ALL SELECT 'robot_model') d) g
  GROUP BY 1, 2, 3, 4;
INSERT INTO report_robot_counts (parameter_set, dimension, group_key, robots)
  SELECT parameter_set, dimension, group_key, COUNT(*) FROM report_robot_presence GROUP BY 1, 2, 3;
)sql",
      // 8: workers lease the oldest job of their kind; without kind in an index the lease walked past every
      // queued job of other kinds (the coordinator's reprocess lease past a backlog of analyze_run jobs).
      R"sql(
CREATE INDEX jobs_by_kind_state ON jobs (kind, state, job_id);
)sql",
      // 9: what decided a region's class (the run's own views, or the map-only classifier), so the run page
      // can say why a region is called a protrusion. Regions stored before keep an empty value.
      R"sql(
ALTER TABLE protrusion_regions ADD COLUMN decided_by TEXT NOT NULL DEFAULT '';
)sql",
      // 10: a robot's newest, current (newest approved) and pending versions, and the version holding a
      // snapshot, are index probes instead of walks of its history (the robots page, GetMap, every upload);
      // robots waiting for review come from the partial index.
      R"sql(
CREATE INDEX map_versions_by_approval ON map_versions (robot_id, approval, version);
CREATE INDEX map_versions_by_snapshot ON map_versions (robot_id, snapshot_id, version);
CREATE INDEX map_versions_pending ON map_versions (robot_id) WHERE approval = 'pending';
)sql",
  };
  return kMigrations;
}

std::string ReplaceAll(std::string text, const std::string& token, const std::string& value) {
  for (std::size_t at = text.find(token); at != std::string::npos; at = text.find(token, at + value.size())) {
    text.replace(at, token.size(), value);
  }
  return text;
}

std::string ForDialect(const std::string& sql, Dialect dialect) {
  const bool sqlite = dialect == Dialect::kSqlite;
  std::string out = ReplaceAll(sql, "${BLOB}", sqlite ? "BLOB" : "BYTEA");
  return ReplaceAll(
      out, "${ID}",
      sqlite ? "INTEGER PRIMARY KEY AUTOINCREMENT" : "BIGINT GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY");
}

std::int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

std::int64_t LatestSchemaVersionInternal() { return static_cast<std::int64_t>(Migrations().size()); }

Result<std::int64_t> ReadSchemaVersion(SqlTransaction& transaction) {
  ASSIGN_OR_RETURN(auto rows, transaction.Query("SELECT MAX(version) FROM schema_version", {}));
  if (rows.empty() || rows.front().IsNull(0)) return std::int64_t{0};
  return rows.front().Int(0);
}

Status MigrateToLatest(SqlDatabase& database) { return MigrateTo(database, LatestSchemaVersionInternal()); }

Status MigrateTo(SqlDatabase& database, std::int64_t target_version) {
  if (target_version < 0 || target_version > LatestSchemaVersionInternal()) {
    return InvalidArgument("no schema version " + std::to_string(target_version));
  }
  return database.InTransaction(TransactionMode::kWrite, [&](SqlTransaction& transaction) -> Status {
    if (database.dialect() == Dialect::kPostgres) {
      // Several servers may start at once against one PostgreSQL: let one migrate, the others wait.
      RETURN_IF_ERROR(transaction.Exec("SELECT pg_advisory_xact_lock(7140424601)", {}));
    }
    RETURN_IF_ERROR(
        transaction.ExecScript("CREATE TABLE IF NOT EXISTS schema_version (version BIGINT PRIMARY KEY, "
                               "applied_at_ms BIGINT NOT NULL)"));
    ASSIGN_OR_RETURN(auto current, ReadSchemaVersion(transaction));
    const std::int64_t latest = target_version;
    if (current > LatestSchemaVersionInternal()) {
      return FailedPrecondition("database schema version " + std::to_string(current) +
                                " is newer than this program's " +
                                std::to_string(LatestSchemaVersionInternal()) + "; upgrade the program");
    }
    for (std::int64_t version = current + 1; version <= latest; ++version) {
      const std::string& sql = Migrations()[static_cast<std::size_t>(version - 1)];
      Status applied = transaction.ExecScript(ForDialect(sql, database.dialect()));
      if (!applied.ok()) {
        return Status(applied.code(),
                      "schema migration " + std::to_string(version) + " failed: " + applied.message());
      }
      RETURN_IF_ERROR(transaction.Exec("INSERT INTO schema_version (version, applied_at_ms) VALUES ($1, $2)",
                                       {SqlValue{version}, SqlValue{NowMs()}}));
    }
    return Status::Ok();
  });
}

}  // namespace storage::internal
