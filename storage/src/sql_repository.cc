// SqlRepository: robots, credentials, snapshots, parameter sets and models.
#include "sql_repository.h"

#include <algorithm>

#include "blob_codec.h"
#include "crypto.h"
#include "migrations.h"

namespace storage::internal {

std::int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

Status CheckText(const std::string& value, const std::string& field, std::size_t max_bytes) {
  if (value.size() > max_bytes) {
    return InvalidArgument(field + " is " + std::to_string(value.size()) + " bytes; at most " +
                           std::to_string(max_bytes) + " allowed");
  }
  if (value.find('\0') != std::string::npos) return InvalidArgument(field + " contains a NUL byte");
  return Status::Ok();
}

Result<InsertOutcome> SqlRepository::CompareExisting(SqlTransaction& transaction,
                                                     const std::string& select_digest_sql,
                                                     const std::vector<SqlValue>& key,
                                                     const std::string& sha256, const std::string& what) {
  ASSIGN_OR_RETURN(auto rows, transaction.Query(select_digest_sql, key));
  if (rows.empty()) return Internal(what + " vanished while being inserted");
  if (rows.front().Text(0) == sha256) return InsertOutcome::kAlreadyPresent;
  return AlreadyExists(what + " is already stored with different content");
}

Result<std::int64_t> SqlRepository::SchemaVersion() {
  std::int64_t version = 0;
  Status status = Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto read, ReadSchemaVersion(transaction));
    version = read;
    return Status::Ok();
  });
  RETURN_IF_ERROR(status);
  return version;
}

// ---- Robots ----

namespace {

constexpr const char* kRobotColumns = "robot_id, robot_model, firmware, registered_at_ms";

}  // namespace

RobotRecord RobotFromRow(const SqlRow& row) {
  return RobotRecord{row.Text(0), row.Text(1), row.Text(2), row.Int(3)};
}

Status CheckRobot(const RobotRecord& robot) {
  if (robot.robot_id.empty()) return InvalidArgument("robot_id is empty");
  RETURN_IF_ERROR(CheckText(robot.robot_id, "robot_id", 128));
  RETURN_IF_ERROR(CheckText(robot.robot_model, "robot_model"));
  return CheckText(robot.firmware, "firmware");
}

Status SqlRepository::PutRobotIn(SqlTransaction& transaction, const RobotRecord& robot) {
  const std::int64_t registered = robot.registered_at_ms != 0 ? robot.registered_at_ms : NowMs();
  return transaction.Exec(
      "INSERT INTO robots (robot_id, robot_model, firmware, registered_at_ms) VALUES ($1, $2, $3, $4) "
      "ON CONFLICT (robot_id) DO UPDATE SET robot_model = excluded.robot_model, firmware = "
      "excluded.firmware",
      {robot.robot_id, robot.robot_model, robot.firmware, registered});
}

Status SqlRepository::PutRobot(const RobotRecord& robot) {
  RETURN_IF_ERROR(CheckRobot(robot));
  return Write([&](SqlTransaction& transaction) { return PutRobotIn(transaction, robot); });
}

Result<RobotRecord> SqlRepository::GetRobot(const std::string& robot_id) {
  std::optional<RobotRecord> robot;
  Status status = Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows, transaction.Query(std::string("SELECT ") + kRobotColumns +
                                                      " FROM robots WHERE robot_id = $1",
                                                  {robot_id}));
    if (!rows.empty()) robot = RobotFromRow(rows.front());
    return Status::Ok();
  });
  RETURN_IF_ERROR(status);
  if (!robot) return NotFound("no robot " + robot_id);
  return *robot;
}

Result<std::vector<RobotRecord>> SqlRepository::ListRobots() {
  std::vector<RobotRecord> robots;
  Status status = Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(std::string("SELECT ") + kRobotColumns + " FROM robots ORDER BY robot_id", {}));
    for (const SqlRow& row : rows) robots.push_back(RobotFromRow(row));
    return Status::Ok();
  });
  RETURN_IF_ERROR(status);
  return robots;
}

// ---- Credentials ----

Status SqlRepository::SetCredential(const std::string& principal, const std::string& secret) {
  if (principal.empty()) return InvalidArgument("principal is empty");
  RETURN_IF_ERROR(CheckText(principal, "principal", 256));
  if (secret.empty()) return InvalidArgument("secret is empty");
  const PasswordHash hashed = HashTokenSecret(secret);
  return Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto epoch, NextCredentialEpoch(transaction));
    return transaction.Exec(
        "INSERT INTO credentials (principal, algorithm, iterations, salt, hash, updated_at_ms, epoch) "
        "VALUES ($1, 'salted-sha256', $2, $3, $4, $5, $6) ON CONFLICT (principal) DO UPDATE SET "
        "algorithm = excluded.algorithm, iterations = excluded.iterations, salt = excluded.salt, "
        "hash = excluded.hash, updated_at_ms = excluded.updated_at_ms, epoch = excluded.epoch",
        {principal, hashed.iterations, SqlBlob{hashed.salt}, SqlBlob{hashed.hash}, NowMs(), epoch});
  });
}

Result<bool> SqlRepository::VerifyCredential(const std::string& principal, const std::string& secret) {
  std::optional<PasswordHash> stored;
  std::string algorithm;
  Status status = Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query("SELECT salt, hash, iterations, algorithm FROM credentials WHERE principal = $1",
                          {principal}));
    if (!rows.empty()) {
      stored = PasswordHash{rows.front().Text(0), rows.front().Text(1), rows.front().Int(2)};
      algorithm = rows.front().Text(3);
    }
    return Status::Ok();
  });
  RETURN_IF_ERROR(status);
  if (!stored || algorithm == kRevokedAlgorithm) {
    // Equal work for an unknown principal: the same hash over a throwaway record, so timing says nothing.
    static const PasswordHash kDummy = HashTokenSecret("no such principal");
    VerifyTokenSecret(secret, kDummy);
    return false;
  }
  if (algorithm == "salted-sha256") return VerifyTokenSecret(secret, *stored);
  if (algorithm != "pbkdf2-hmac-sha256") return false;
  // A credential from before "salted-sha256": verified the slow way once, then rewritten the fast way.
  if (!VerifySecret(secret, *stored)) return false;
  RETURN_IF_ERROR(SetCredential(principal, secret));
  return true;
}

// ---- Snapshots ----

Result<SqlRepository::SnapshotsToStore> SqlRepository::EncodeNewSnapshots(
    const std::vector<const std::string*>& snapshots) {
  SnapshotsToStore result;
  for (const std::string* bytes : snapshots) result.ids.push_back(Sha256Hex(*bytes));
  std::vector<bool> stored(snapshots.size(), false);
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    for (std::size_t i = 0; i < snapshots.size(); ++i) {
      ASSIGN_OR_RETURN(auto rows,
                       transaction.Query("SELECT 1 FROM snapshots WHERE snapshot_id = $1", {result.ids[i]}));
      stored[i] = !rows.empty();
    }
    return Status::Ok();
  }));
  for (std::size_t i = 0; i < snapshots.size(); ++i) {
    const std::string& id = result.ids[i];
    const bool repeated = std::any_of(result.absent.begin(), result.absent.end(),
                                      [&](const EncodedSnapshot& kept) { return kept.id == id; });
    if (!stored[i] && !repeated) result.absent.push_back({id, EncodeBlob(*snapshots[i])});
  }
  return result;
}

Status SqlRepository::PutSnapshotIn(SqlTransaction& transaction, const EncodedSnapshot& snapshot) {
  return transaction.Exec(
      "INSERT INTO snapshots (snapshot_id, data, data_crc32, data_size, created_at_ms) VALUES ($1, $2, $3, "
      "$4, $5) "
      "ON CONFLICT (snapshot_id) DO NOTHING",
      {snapshot.id, SqlBlob{snapshot.blob.compressed}, snapshot.blob.crc32, snapshot.blob.raw_size, NowMs()});
}

Result<std::string> SqlRepository::PutSnapshot(const std::string& bytes) {
  ASSIGN_OR_RETURN(auto snapshots, EncodeNewSnapshots({&bytes}));
  if (!snapshots.absent.empty()) {
    RETURN_IF_ERROR(
        Write([&](SqlTransaction& transaction) { return PutSnapshotIn(transaction, snapshots.absent[0]); }));
  }
  return snapshots.ids[0];
}

Result<SnapshotRecord> SqlRepository::GetSnapshot(const std::string& snapshot_id) {
  std::optional<SqlRow> row;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query("SELECT data, data_crc32, data_size FROM snapshots WHERE snapshot_id = $1",
                          {snapshot_id}));
    if (!rows.empty()) row = rows.front();
    return Status::Ok();
  }));
  if (!row) return NotFound("no snapshot " + snapshot_id);
  ASSIGN_OR_RETURN(auto bytes, DecodeBlob(row->Text(0), row->Int(1), row->Int(2), "snapshot " + snapshot_id));
  if (Sha256Hex(bytes) != snapshot_id)
    return DataLoss("snapshot " + snapshot_id + ": bytes do not match their id");
  return SnapshotRecord{snapshot_id, std::move(bytes)};
}

// ---- Parameter sets ----

Result<InsertOutcome> SqlRepository::PutParameterSet(const ParameterSetRecord& parameter_set) {
  if (parameter_set.name.empty()) return InvalidArgument("parameter set name is empty");
  RETURN_IF_ERROR(CheckText(parameter_set.name, "parameter set name", 128));
  const std::string sha256 = Sha256Hex(parameter_set.serialized);
  const EncodedBlob blob = EncodeBlob(parameter_set.serialized);
  InsertOutcome outcome = InsertOutcome::kInserted;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto inserted,
        transaction.Query(
            "INSERT INTO parameter_sets (name, data, data_crc32, data_size, data_sha256, created_at_ms) "
            "VALUES ($1, $2, $3, $4, $5, $6) ON CONFLICT (name) DO NOTHING RETURNING name",
            {parameter_set.name, SqlBlob{blob.compressed}, blob.crc32, blob.raw_size, sha256, NowMs()}));
    if (!inserted.empty()) return Status::Ok();
    ASSIGN_OR_RETURN(auto existing,
                     CompareExisting(transaction, "SELECT data_sha256 FROM parameter_sets WHERE name = $1",
                                     {parameter_set.name}, sha256, "parameter set " + parameter_set.name));
    outcome = existing;
    return Status::Ok();
  }));
  return outcome;
}

Result<ParameterSetRecord> SqlRepository::GetParameterSet(const std::string& name) {
  std::optional<SqlRow> row;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query("SELECT data, data_crc32, data_size FROM parameter_sets WHERE name = $1", {name}));
    if (!rows.empty()) row = rows.front();
    return Status::Ok();
  }));
  if (!row) return NotFound("no parameter set " + name);
  ASSIGN_OR_RETURN(auto bytes, DecodeBlob(row->Text(0), row->Int(1), row->Int(2), "parameter set " + name));
  return ParameterSetRecord{name, std::move(bytes)};
}

Result<std::vector<std::string>> SqlRepository::ListParameterSetNames() {
  std::vector<std::string> names;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows, transaction.Query("SELECT name FROM parameter_sets ORDER BY name", {}));
    for (const SqlRow& row : rows) names.push_back(row.Text(0));
    return Status::Ok();
  }));
  return names;
}

// ---- Models ----

Result<InsertOutcome> SqlRepository::PutModel(const ModelRecord& model) {
  if (model.name.empty()) return InvalidArgument("model name is empty");
  RETURN_IF_ERROR(CheckText(model.name, "model name", 128));
  const std::string sha256 = Sha256Hex(model.bytes);
  const EncodedBlob blob = EncodeBlob(model.bytes);
  InsertOutcome outcome = InsertOutcome::kInserted;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto inserted,
        transaction.Query(
            "INSERT INTO models (name, version, data, data_crc32, data_size, data_sha256, active, "
            "created_at_ms) "
            "VALUES ($1, $2, $3, $4, $5, $6, 0, $7) ON CONFLICT (name, version) DO NOTHING RETURNING name",
            {model.name, model.version, SqlBlob{blob.compressed}, blob.crc32, blob.raw_size, sha256,
             NowMs()}));
    if (inserted.empty()) {
      ASSIGN_OR_RETURN(
          auto existing,
          CompareExisting(transaction, "SELECT data_sha256 FROM models WHERE name = $1 AND version = $2",
                          {model.name, model.version}, sha256,
                          "model " + model.name + " version " + std::to_string(model.version)));
      outcome = existing;
    }
    if (!model.active) return Status::Ok();
    return transaction.Exec(
        "UPDATE models SET active = CASE WHEN version = $2 THEN 1 ELSE 0 END WHERE name = $1",
        {model.name, model.version});
  }));
  return outcome;
}

namespace {

Result<ModelRecord> ModelFromRow(const SqlRow& row) {
  ModelRecord model{row.Text(0), row.Int(1), {}, row.Int(5) != 0};
  ASSIGN_OR_RETURN(auto bytes,
                   DecodeBlob(row.Text(2), row.Int(3), row.Int(4),
                              "model " + model.name + " version " + std::to_string(model.version)));
  model.bytes = std::move(bytes);
  return model;
}

constexpr const char* kModelColumns =
    "SELECT name, version, data, data_crc32, data_size, active FROM models ";

}  // namespace

Result<ModelRecord> SqlRepository::GetModel(const std::string& name, std::int64_t version) {
  std::optional<SqlRow> row;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(std::string(kModelColumns) + "WHERE name = $1 AND version = $2", {name, version}));
    if (!rows.empty()) row = rows.front();
    return Status::Ok();
  }));
  if (!row) return NotFound("no model " + name + " version " + std::to_string(version));
  return ModelFromRow(*row);
}

Result<ModelRecord> SqlRepository::GetActiveModel(const std::string& name) {
  std::optional<SqlRow> row;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows, transaction.Query(std::string(kModelColumns) + "WHERE name = $1 AND active = 1", {name}));
    if (!rows.empty()) row = rows.front();
    return Status::Ok();
  }));
  if (!row) return NotFound("no active model " + name);
  return ModelFromRow(*row);
}

Status SqlRepository::ActivateModel(const std::string& name, std::int64_t version) {
  return Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows, transaction.Query("SELECT 1 FROM models WHERE name = $1 AND version = $2",
                                                  {name, version}));
    if (rows.empty()) return NotFound("no model " + name + " version " + std::to_string(version));
    return transaction.Exec(
        "UPDATE models SET active = CASE WHEN version = $2 THEN 1 ELSE 0 END WHERE name = $1",
        {name, version});
  });
}

}  // namespace storage::internal
