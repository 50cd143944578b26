// The small seam under SqlRepository: run parameterised statements inside a transaction. Two drivers
// implement it: SQLite (sqlite3 C API) and PostgreSQL (libpqxx). The repository's SQL is written once, in
// the subset both databases share, with numbered placeholders $1, $2, ... bound as parameters.
//
// Thread safety: SqlDatabase::InTransaction may be called from many threads; a SqlTransaction belongs to
// the one call that received it.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "storage/status.h"

namespace storage::internal {

struct SqlNull {};
struct SqlBlob {
  std::string bytes;
};
using SqlValue = std::variant<SqlNull, std::int64_t, double, std::string, SqlBlob>;

/// One result row; accessors convert leniently because the schema, not the caller, fixes the types.
class SqlRow {
 public:
  explicit SqlRow(std::vector<SqlValue> values) : values_(std::move(values)) {}
  std::size_t size() const { return values_.size(); }
  bool IsNull(std::size_t i) const { return std::holds_alternative<SqlNull>(values_.at(i)); }
  std::int64_t Int(std::size_t i) const;
  double Real(std::size_t i) const;
  std::string Text(std::size_t i) const;  // also returns a blob's bytes
  const std::vector<SqlValue>& values() const { return values_; }

 private:
  std::vector<SqlValue> values_;
};

using SqlRows = std::vector<SqlRow>;

enum class Dialect { kSqlite, kPostgres };
enum class TransactionMode { kRead, kWrite };

class SqlTransaction {
 public:
  virtual ~SqlTransaction() = default;
  /// Runs one statement with parameters bound to $1..$N (prepared once per connection and reused).
  virtual Result<SqlRows> Query(const std::string& sql, const std::vector<SqlValue>& params) = 0;
  /// Runs a parameterless script of several statements (schema migrations only).
  virtual Status ExecScript(const std::string& script) = 0;

  /// Query without rows.
  Status Exec(const std::string& sql, const std::vector<SqlValue>& params);
};

class SqlDatabase {
 public:
  virtual ~SqlDatabase() = default;
  virtual Dialect dialect() const = 0;
  /// Runs `body` in one transaction: commits when it returns OK, rolls back otherwise (and on a crash).
  /// kWrite transactions take the write lock up front where the database has one (SQLite BEGIN IMMEDIATE).
  virtual Status InTransaction(TransactionMode mode, const std::function<Status(SqlTransaction&)>& body) = 0;
};

}  // namespace storage::internal
