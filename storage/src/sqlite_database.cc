#include "sqlite_database.h"

#include <sqlite3.h>

#include <mutex>
#include <unordered_map>

namespace storage::internal {
namespace {

Status SqliteError(sqlite3* db, int rc, const std::string& context) {
  const std::string message = context + ": " + (db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
  switch (rc & 0xFF) {  // the primary result code
    case SQLITE_NOTADB:
    case SQLITE_CORRUPT: return DataLoss(message + " (the file is not a SQLite database or is corrupt)");
    case SQLITE_BUSY:
    case SQLITE_LOCKED: return Unavailable(message);
    // The database cannot take writes now (disk full, file or directory read-only, I/O failing): retry
    // later, once an operator freed space or fixed permissions; nothing is wrong with the request.
    case SQLITE_FULL:
    case SQLITE_READONLY:
    case SQLITE_IOERR:
    case SQLITE_CANTOPEN:
    case SQLITE_PROTOCOL: return Unavailable(message);
    case SQLITE_CONSTRAINT:
      if (rc == SQLITE_CONSTRAINT_FOREIGNKEY)
        return FailedPrecondition(message + " (a referenced record is missing)");
      if (rc == SQLITE_CONSTRAINT_PRIMARYKEY || rc == SQLITE_CONSTRAINT_UNIQUE) return AlreadyExists(message);
      return InvalidArgument(message);
    case SQLITE_TOOBIG: return InvalidArgument(message);
    default: return Internal(message);
  }
}

class SqliteDatabase;

class SqliteTransaction final : public SqlTransaction {
 public:
  explicit SqliteTransaction(SqliteDatabase& database) : database_(database) {}
  Result<SqlRows> Query(const std::string& sql, const std::vector<SqlValue>& params) override;
  Status ExecScript(const std::string& script) override;

 private:
  SqliteDatabase& database_;
};

class SqliteDatabase final : public SqlDatabase {
 public:
  explicit SqliteDatabase(sqlite3* db) : db_(db) {}
  ~SqliteDatabase() override {
    for (auto& [sql, statement] : statements_) sqlite3_finalize(statement);
    sqlite3_close_v2(db_);
  }
  SqliteDatabase(const SqliteDatabase&) = delete;
  SqliteDatabase& operator=(const SqliteDatabase&) = delete;

  Dialect dialect() const override { return Dialect::kSqlite; }

  Status InTransaction(TransactionMode mode, const std::function<Status(SqlTransaction&)>& body) override {
    std::lock_guard<std::mutex> lock(mutex_);
    // IMMEDIATE takes the write lock now, so a write transaction never fails half-way on lock upgrade.
    const char* begin = mode == TransactionMode::kWrite ? "BEGIN IMMEDIATE" : "BEGIN DEFERRED";
    RETURN_IF_ERROR(ExecLocked(begin));
    SqliteTransaction transaction(*this);
    Status status;
    try {
      status = body(transaction);
    } catch (...) {
      (void)ExecLocked("ROLLBACK");
      throw;
    }
    if (!status.ok()) {
      (void)ExecLocked("ROLLBACK");
      return status;
    }
    Status committed = ExecLocked("COMMIT");
    if (!committed.ok()) (void)ExecLocked("ROLLBACK");
    return committed;
  }

  /// Caller holds mutex_ (inside InTransaction).
  Status ExecLocked(const std::string& script) {
    char* error = nullptr;
    const int rc = sqlite3_exec(db_, script.c_str(), nullptr, nullptr, &error);
    if (rc == SQLITE_OK) return Status::Ok();
    std::string message = error != nullptr ? error : sqlite3_errstr(rc);
    sqlite3_free(error);
    return SqliteError(nullptr, sqlite3_extended_errcode(db_), "sqlite: " + message);
  }

  /// Caller holds mutex_.
  Result<SqlRows> QueryLocked(const std::string& sql, const std::vector<SqlValue>& params) {
    ASSIGN_OR_RETURN(auto statement, Prepare(sql));
    sqlite3_stmt* stmt = statement;
    // Reset on every exit so the cached statement releases its read snapshot and bindings.
    struct Resetter {
      sqlite3_stmt* stmt;
      ~Resetter() {
        sqlite3_reset(stmt);
        sqlite3_clear_bindings(stmt);
      }
    } resetter{stmt};
    for (std::size_t i = 0; i < params.size(); ++i) {
      std::string name = "$";  // (built with += : GCC 12 misreports "literal" + string under -Wrestrict)
      name += std::to_string(i + 1);
      const int index = sqlite3_bind_parameter_index(stmt, name.c_str());
      if (index == 0) continue;  // this statement does not use $i
      int rc = SQLITE_OK;
      const SqlValue& value = params[i];
      if (std::holds_alternative<SqlNull>(value)) {
        rc = sqlite3_bind_null(stmt, index);
      } else if (auto* integer = std::get_if<std::int64_t>(&value)) {
        rc = sqlite3_bind_int64(stmt, index, *integer);
      } else if (auto* real = std::get_if<double>(&value)) {
        rc = sqlite3_bind_double(stmt, index, *real);
      } else if (auto* text = std::get_if<std::string>(&value)) {
        rc = sqlite3_bind_text64(stmt, index, text->data(), text->size(), SQLITE_STATIC, SQLITE_UTF8);
      } else {
        const std::string& bytes = std::get<SqlBlob>(value).bytes;
        rc = sqlite3_bind_blob64(stmt, index, bytes.data(), bytes.size(), SQLITE_STATIC);
      }
      if (rc != SQLITE_OK) return SqliteError(db_, rc, "sqlite bind " + name);
    }
    SqlRows rows;
    for (;;) {
      const int rc = sqlite3_step(stmt);
      if (rc == SQLITE_DONE) break;
      if (rc != SQLITE_ROW) return SqliteError(db_, sqlite3_extended_errcode(db_), "sqlite");
      const int columns = sqlite3_column_count(stmt);
      std::vector<SqlValue> values;
      values.reserve(static_cast<std::size_t>(columns));
      for (int c = 0; c < columns; ++c) {
        switch (sqlite3_column_type(stmt, c)) {
          case SQLITE_NULL: values.emplace_back(SqlNull{}); break;
          case SQLITE_INTEGER: values.emplace_back(std::int64_t{sqlite3_column_int64(stmt, c)}); break;
          case SQLITE_FLOAT: values.emplace_back(sqlite3_column_double(stmt, c)); break;
          case SQLITE_BLOB: {
            const void* data = sqlite3_column_blob(stmt, c);
            const int size = sqlite3_column_bytes(stmt, c);
            values.emplace_back(
                SqlBlob{std::string(static_cast<const char*>(data), static_cast<std::size_t>(size))});
            break;
          }
          default: {
            const unsigned char* data = sqlite3_column_text(stmt, c);
            const int size = sqlite3_column_bytes(stmt, c);
            values.emplace_back(
                std::string(reinterpret_cast<const char*>(data), static_cast<std::size_t>(size)));
          }
        }
      }
      rows.emplace_back(std::move(values));
    }
    return rows;
  }

 private:
  Result<sqlite3_stmt*> Prepare(const std::string& sql) {
    if (auto it = statements_.find(sql); it != statements_.end()) return it->second;
    sqlite3_stmt* stmt = nullptr;
    const int rc = sqlite3_prepare_v3(db_, sql.c_str(), static_cast<int>(sql.size() + 1),
                                      SQLITE_PREPARE_PERSISTENT, &stmt, nullptr);
    if (rc != SQLITE_OK) return SqliteError(db_, rc, "sqlite prepare");
    statements_.emplace(sql, stmt);
    return stmt;
  }

  std::mutex mutex_;  // guards db_ and statements_; held for a whole transaction
  sqlite3* db_;
  std::unordered_map<std::string, sqlite3_stmt*> statements_;
};

Result<SqlRows> SqliteTransaction::Query(const std::string& sql, const std::vector<SqlValue>& params) {
  return database_.QueryLocked(sql, params);
}

Status SqliteTransaction::ExecScript(const std::string& script) { return database_.ExecLocked(script); }

}  // namespace

Result<std::unique_ptr<SqlDatabase>> OpenSqliteDatabase(const std::string& path,
                                                        std::chrono::milliseconds busy_timeout) {
  if (path.empty()) return InvalidArgument("sqlite: empty file path");
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db,
                                 SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    Status error = SqliteError(db, rc, "sqlite: cannot open " + path);
    sqlite3_close_v2(db);
    return error.code() == StatusCode::kInternal ? Unavailable(error.message()) : error;
  }
  sqlite3_extended_result_codes(db, 1);
  auto database = std::make_unique<SqliteDatabase>(db);
  // journal_mode is the first statement that reads the file, so a non-database is reported here. Nothing
  // else can reach `database` yet, so running without its mutex is safe.
  const std::string pragmas = "PRAGMA busy_timeout=" + std::to_string(busy_timeout.count()) +
                              "; PRAGMA journal_mode=WAL; PRAGMA foreign_keys=ON; PRAGMA synchronous=FULL;";
  Status configured = database->ExecLocked(pragmas);
  if (!configured.ok()) {
    return Status(configured.code(), "sqlite:" + path + ": " + configured.message());
  }
  return std::unique_ptr<SqlDatabase>(std::move(database));
}

}  // namespace storage::internal
