// SqlRepository: reports with their decisions, ambiguous views and protrusion regions.
#include <map>

#include "blob_codec.h"
#include "sql_repository.h"

namespace storage::internal {
namespace {

constexpr std::size_t kMaxDetailBytes = 1 << 20;

Status CheckBundle(const ReportBundle& bundle) {
  const ReportRecord& report = bundle.report;
  if (report.robot_id.empty()) return InvalidArgument("report robot_id is empty");
  if (report.run_id.empty()) return InvalidArgument("report run_id is empty");
  RETURN_IF_ERROR(CheckText(report.robot_id, "report robot_id", 128));
  if (report.parameter_set.empty()) return InvalidArgument("report parameter_set is empty");
  RETURN_IF_ERROR(CheckText(report.run_id, "report run_id", 128));
  RETURN_IF_ERROR(CheckText(report.parameter_set, "report parameter_set", 128));
  for (const DecisionRecord& decision : bundle.decisions) {
    RETURN_IF_ERROR(CheckText(decision.kind, "decision kind"));
    RETURN_IF_ERROR(CheckText(decision.outcome, "decision outcome"));
    RETURN_IF_ERROR(CheckText(decision.detail, "decision detail", kMaxDetailBytes));
  }
  for (const AmbiguousViewRecord& view : bundle.ambiguous_views) {
    RETURN_IF_ERROR(CheckText(view.detail, "ambiguous view detail", kMaxDetailBytes));
  }
  for (const ProtrusionRegionRecord& region : bundle.protrusion_regions) {
    RETURN_IF_ERROR(CheckText(region.features_json, "region features_json", kMaxDetailBytes));
    RETURN_IF_ERROR(CheckText(region.predicted_class, "region predicted_class"));
    RETURN_IF_ERROR(CheckText(region.decided_by, "region decided_by"));
  }
  return Status::Ok();
}

struct Label {
  std::string label;
  std::string labelled_by;
};

constexpr const char* kRegionColumns =
    "SELECT run_id, parameter_set, region_id, min_x, min_y, max_x, max_y, features_json, predicted_class, "
    "probability, label, labelled_by, robot_id, decided_by FROM protrusion_regions ";

ProtrusionRegionRecord RegionFromRow(const SqlRow& row) {
  ProtrusionRegionRecord region;
  region.run_id = row.Text(0);
  region.parameter_set = row.Text(1);
  region.region_id = row.Int(2);
  region.bbox = BoundingBox{row.Real(3), row.Real(4), row.Real(5), row.Real(6)};
  region.features_json = row.Text(7);
  region.predicted_class = row.Text(8);
  region.probability = row.Real(9);
  if (!row.IsNull(10)) region.label = row.Text(10);
  if (!row.IsNull(11)) region.labelled_by = row.Text(11);
  region.robot_id = row.Text(12);
  region.decided_by = row.Text(13);
  return region;
}

}  // namespace

Status SqlRepository::PutReport(const ReportBundle& bundle) {
  RETURN_IF_ERROR(CheckBundle(bundle));
  const EncodedBlob blob = EncodeBlob(bundle.report.report);
  return Write([&](SqlTransaction& transaction) -> Status {
    RETURN_IF_ERROR(PutReportIn(transaction, bundle, blob));
    Fault("put_report:before_commit");
    return Status::Ok();
  });
}

Status SqlRepository::PutReports(const std::vector<ReportBundle>& bundles) {
  if (bundles.size() > 10000) return InvalidArgument("reports: at most 10000 per batch");
  std::vector<EncodedBlob> blobs;
  for (const ReportBundle& bundle : bundles) {
    RETURN_IF_ERROR(CheckBundle(bundle));
    blobs.push_back(EncodeBlob(bundle.report.report));
  }
  return Write([&](SqlTransaction& transaction) -> Status {
    for (std::size_t i = 0; i < bundles.size(); ++i)
      RETURN_IF_ERROR(PutReportIn(transaction, bundles[i], blobs[i]));
    return Status::Ok();
  });
}

Status SqlRepository::PutReportIn(SqlTransaction& transaction, const ReportBundle& bundle,
                                  const EncodedBlob& blob) {
  const ReportRecord& report = bundle.report;
  const std::vector<SqlValue> key = {report.robot_id, report.run_id, report.parameter_set};
  const std::vector<SqlValue> values = {report.robot_id,
                                        report.run_id,
                                        report.parameter_set,
                                        report.recovery_created,
                                        report.recovery_accepted,
                                        report.merge_created,
                                        report.merge_conditionally_accepted,
                                        report.merge_conditional_then_rejected,
                                        report.views_total,
                                        report.views_ambiguous,
                                        std::int64_t{report.started_localized ? 1 : 0},
                                        report.protrusions_found,
                                        SqlBlob{blob.compressed},
                                        blob.crc32,
                                        blob.raw_size,
                                        NowMs(),
                                        report.recovery_retracted};
  // A new report or a replacement: the roll-up adds the difference, so it must know the counters replaced.
  // Either statement locks the report row first, so concurrent writers of one key take turns and each sees
  // the counters the other committed.
  ASSIGN_OR_RETURN(
      auto inserted,
      transaction.Query(
          "INSERT INTO reports (robot_id, run_id, parameter_set, recovery_created, recovery_accepted, "
          "merge_created, "
          "merge_conditionally_accepted, merge_conditional_then_rejected, views_total, views_ambiguous, "
          "started_localized, protrusions_found, data, data_crc32, data_size, created_at_ms, "
          "recovery_retracted) "
          "VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17) "
          "ON CONFLICT (robot_id, run_id, parameter_set) DO NOTHING RETURNING run_id",
          values));
  std::optional<ReportRecord> replaced;
  if (inserted.empty()) {
    ASSIGN_OR_RETURN(
        auto previous,
        transaction.Query(
            "UPDATE reports SET data_size = data_size WHERE robot_id = $1 AND run_id = $2 AND parameter_set "
            "= $3 "
            "RETURNING recovery_created, recovery_accepted, merge_created, merge_conditionally_accepted, "
            "merge_conditional_then_rejected, views_total, views_ambiguous, started_localized, "
            "protrusions_found, "
            "recovery_retracted",
            key));
    if (previous.empty()) return Aborted("report of run " + report.run_id + " vanished while being replaced");
    const SqlRow& row = previous.front();
    replaced = ReportRecord{report.robot_id, report.run_id,   report.parameter_set, row.Int(0), row.Int(1),
                            row.Int(9),      row.Int(2),      row.Int(3),           row.Int(4), row.Int(5),
                            row.Int(6),      row.Int(7) != 0, row.Int(8),           {}};
    RETURN_IF_ERROR(transaction.Exec(
        "UPDATE reports SET recovery_created = $4, recovery_accepted = $5, merge_created = $6, "
        "merge_conditionally_accepted = $7, merge_conditional_then_rejected = $8, views_total = $9, "
        "views_ambiguous = $10, started_localized = $11, protrusions_found = $12, data = $13, data_crc32 = "
        "$14, "
        "data_size = $15, created_at_ms = $16, recovery_retracted = $17 "
        "WHERE robot_id = $1 AND run_id = $2 AND parameter_set = $3",
        values));
  }
  RETURN_IF_ERROR(AddReportToRollup(transaction, report, replaced));

  // Labels are an engineer's work: carry them over to the replacement rows of the same region ids. A new
  // report has no rows to replace.
  std::map<std::int64_t, Label> labels;
  if (replaced) {
    ASSIGN_OR_RETURN(auto labelled,
                     transaction.Query("SELECT region_id, label, labelled_by FROM protrusion_regions WHERE "
                                       "robot_id = $1 AND run_id = $2 "
                                       "AND parameter_set = $3 AND label IS NOT NULL",
                                       key));
    for (const SqlRow& row : labelled) labels[row.Int(0)] = Label{row.Text(1), row.Text(2)};
    for (const char* table : {"decisions", "ambiguous_views", "protrusion_regions"}) {
      RETURN_IF_ERROR(transaction.Exec(
          std::string("DELETE FROM ") + table + " WHERE robot_id = $1 AND run_id = $2 AND parameter_set = $3",
          key));
    }
  }
  for (const DecisionRecord& d : bundle.decisions) {
    RETURN_IF_ERROR(
        transaction.Exec("INSERT INTO decisions (robot_id, run_id, parameter_set, sequence, time_s, kind, "
                         "outcome, subject_id, score, "
                         "detail) VALUES ($10, $1, $2, $3, $4, $5, $6, $7, $8, $9)",
                         {report.run_id, report.parameter_set, d.sequence, d.time_s, d.kind, d.outcome,
                          d.subject_id, d.score, d.detail, report.robot_id}));
  }
  for (const AmbiguousViewRecord& v : bundle.ambiguous_views) {
    RETURN_IF_ERROR(
        transaction.Exec("INSERT INTO ambiguous_views (robot_id, run_id, parameter_set, view_id, time_s, "
                         "candidate_count, ambiguity, "
                         "detail) VALUES ($8, $1, $2, $3, $4, $5, $6, $7)",
                         {report.run_id, report.parameter_set, v.view_id, v.time_s, v.candidate_count,
                          v.ambiguity, v.detail, report.robot_id}));
  }
  for (const ProtrusionRegionRecord& r : bundle.protrusion_regions) {
    SqlValue label = SqlNull{}, labelled_by = SqlNull{};
    if (auto it = labels.find(r.region_id); it != labels.end()) {
      label = it->second.label;
      labelled_by = it->second.labelled_by;
    } else if (r.label) {
      label = *r.label;
      labelled_by = r.labelled_by.value_or("");
    }
    RETURN_IF_ERROR(
        transaction.Exec("INSERT INTO protrusion_regions (robot_id, run_id, parameter_set, region_id, min_x, "
                         "min_y, max_x, max_y, "
                         "features_json, predicted_class, probability, label, labelled_by, decided_by) "
                         "VALUES ($13, $1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $14)",
                         {report.run_id, report.parameter_set, r.region_id, r.bbox.min_x, r.bbox.min_y,
                          r.bbox.max_x, r.bbox.max_y, r.features_json, r.predicted_class, r.probability,
                          label, labelled_by, report.robot_id, r.decided_by}));
  }
  return Status::Ok();
}

Result<ReportRecord> SqlRepository::GetReport(const RunKey& run, const std::string& parameter_set) {
  const std::string& run_id = run.run_id;
  std::optional<SqlRow> row;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(
            "SELECT recovery_created, recovery_accepted, merge_created, merge_conditionally_accepted, "
            "merge_conditional_then_rejected, views_total, views_ambiguous, started_localized, "
            "protrusions_found, "
            "data, data_crc32, data_size, recovery_retracted FROM reports WHERE robot_id = $1 AND run_id = "
            "$2 "
            "AND parameter_set = $3",
            {run.robot_id, run_id, parameter_set}));
    if (!rows.empty()) row = rows.front();
    return Status::Ok();
  }));
  if (!row) {
    return NotFound("no report for run " + run_id + " of robot " + run.robot_id + " with parameter set " +
                    parameter_set);
  }
  ReportRecord report;
  report.robot_id = run.robot_id;
  report.run_id = run_id;
  report.parameter_set = parameter_set;
  report.recovery_created = row->Int(0);
  report.recovery_accepted = row->Int(1);
  report.merge_created = row->Int(2);
  report.merge_conditionally_accepted = row->Int(3);
  report.merge_conditional_then_rejected = row->Int(4);
  report.views_total = row->Int(5);
  report.views_ambiguous = row->Int(6);
  report.started_localized = row->Int(7) != 0;
  report.protrusions_found = row->Int(8);
  report.recovery_retracted = row->Int(12);
  ASSIGN_OR_RETURN(auto bytes,
                   DecodeBlob(row->Text(9), row->Int(10), row->Int(11),
                              "report of run " + run_id + " with parameter set " + parameter_set));
  report.report = std::move(bytes);
  return report;
}

Result<std::vector<std::string>> SqlRepository::ListReportParameterSets(const RunKey& run) {
  std::vector<std::string> names;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(
            "SELECT parameter_set FROM reports WHERE robot_id = $1 AND run_id = $2 ORDER BY parameter_set",
            {run.robot_id, run.run_id}));
    for (const SqlRow& row : rows) names.push_back(row.Text(0));
    return Status::Ok();
  }));
  return names;
}

Result<std::vector<DecisionRecord>> SqlRepository::ListDecisions(const RunKey& run,
                                                                 const std::string& parameter_set) {
  std::vector<DecisionRecord> decisions;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query("SELECT sequence, time_s, kind, outcome, subject_id, score, detail FROM decisions "
                          "WHERE robot_id = $1 AND run_id = $2 AND parameter_set = $3 ORDER BY sequence",
                          {run.robot_id, run.run_id, parameter_set}));
    for (const SqlRow& row : rows) {
      decisions.push_back(DecisionRecord{row.Int(0), row.Real(1), row.Text(2), row.Text(3), row.Int(4),
                                         row.Real(5), row.Text(6)});
    }
    return Status::Ok();
  }));
  return decisions;
}

Result<std::vector<AmbiguousViewRecord>> SqlRepository::ListAmbiguousViews(const RunKey& run,
                                                                           const std::string& parameter_set) {
  std::vector<AmbiguousViewRecord> views;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query("SELECT view_id, time_s, candidate_count, ambiguity, detail FROM ambiguous_views "
                          "WHERE robot_id = $1 AND run_id = $2 AND parameter_set = $3 ORDER BY view_id",
                          {run.robot_id, run.run_id, parameter_set}));
    for (const SqlRow& row : rows) {
      views.push_back(AmbiguousViewRecord{row.Int(0), row.Real(1), row.Int(2), row.Real(3), row.Text(4)});
    }
    return Status::Ok();
  }));
  return views;
}

Result<std::vector<ProtrusionRegionRecord>> SqlRepository::ListProtrusionRegions(
    const RunKey& run, const std::string& parameter_set) {
  std::vector<ProtrusionRegionRecord> regions;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(std::string(kRegionColumns) +
                              "WHERE robot_id = $1 AND run_id = $2 AND parameter_set = $3 ORDER BY region_id",
                          {run.robot_id, run.run_id, parameter_set}));
    for (const SqlRow& row : rows) regions.push_back(RegionFromRow(row));
    return Status::Ok();
  }));
  return regions;
}

Status SqlRepository::LabelProtrusionRegion(const RunKey& run, const std::string& parameter_set,
                                            std::int64_t region_id, const std::string& label,
                                            const std::string& labelled_by) {
  if (label.empty()) return InvalidArgument("label is empty");
  RETURN_IF_ERROR(CheckText(label, "label", 128));
  RETURN_IF_ERROR(CheckText(labelled_by, "labelled_by", 256));
  return Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query("UPDATE protrusion_regions SET label = $4, labelled_by = $5 "
                          "WHERE run_id = $1 AND parameter_set = $2 AND region_id = $3 AND robot_id = $6 "
                          "RETURNING region_id",
                          {run.run_id, parameter_set, region_id, label, labelled_by, run.robot_id}));
    if (rows.empty()) {
      return NotFound("no protrusion region " + std::to_string(region_id) + " in run " + run.run_id +
                      " of robot " + run.robot_id + " with parameter set " + parameter_set);
    }
    return Status::Ok();
  });
}

Result<std::vector<ProtrusionRegionRecord>> SqlRepository::ListLabelledRegions(
    const std::string& parameter_set, int limit) {
  if (limit < 1) return InvalidArgument("limit must be positive");
  std::vector<ProtrusionRegionRecord> regions;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(std::string(kRegionColumns) +
                              "WHERE label IS NOT NULL AND (CAST($1 AS TEXT) = '' OR parameter_set = $1) "
                              "ORDER BY robot_id, run_id, parameter_set, region_id LIMIT $2",
                          {parameter_set, std::int64_t{limit}}));
    for (const SqlRow& row : rows) regions.push_back(RegionFromRow(row));
    return Status::Ok();
  }));
  return regions;
}

}  // namespace storage::internal
