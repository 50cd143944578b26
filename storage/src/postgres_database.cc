#include "postgres_database.h"

#include <pqxx/pqxx>

#include <charconv>
#include <condition_variable>
#include <mutex>
#include <unordered_map>
#include <unordered_set>

#include "crypto.h"

namespace storage::internal {
namespace {

// PostgreSQL type oids of the columns our schema returns.
constexpr pqxx::oid kBoolOid = 16, kByteaOid = 17, kInt8Oid = 20, kInt2Oid = 21, kInt4Oid = 23,
                    kFloat4Oid = 700, kFloat8Oid = 701, kNumericOid = 1700;

constexpr int kMaxAttempts = 3;  // for serialization failures and deadlocks, which a retry resolves

Status MapSqlError(const pqxx::sql_error& error) {
  const std::string state = error.sqlstate();
  const std::string message = std::string("postgresql: ") + error.what();
  if (state == "23505") return AlreadyExists(message);
  if (state == "23503") return FailedPrecondition(message + " (a referenced record is missing)");
  if (state.rfind("23", 0) == 0 || state.rfind("22", 0) == 0) return InvalidArgument(message);
  // Serialization failures, insufficient resources (53: disk full, out of memory, too many connections),
  // operator intervention (57), connection (08), system errors (58: I/O) and a read-only server (25006, a
  // standby or default_transaction_read_only): the request may succeed later.
  if (state == "40001" || state == "40P01" || state.rfind("53", 0) == 0 || state.rfind("57", 0) == 0 ||
      state.rfind("08", 0) == 0 || state.rfind("58", 0) == 0 || state == "25006") {
    return Unavailable(message);
  }
  if (state == "XX001" || state == "XX002") return DataLoss(message);
  return Internal(message);
}

struct PooledConnection {
  std::unique_ptr<pqxx::connection> connection;
  std::unordered_set<std::string> prepared;  // statement names prepared on this connection
};

class PostgresDatabase;

class PostgresTransaction final : public SqlTransaction {
 public:
  PostgresTransaction(PostgresDatabase& database, PooledConnection& connection, pqxx::work& work)
      : database_(database), connection_(connection), work_(work) {}
  Result<SqlRows> Query(const std::string& sql, const std::vector<SqlValue>& params) override;
  Status ExecScript(const std::string& script) override {
    try {
      work_.exec(script);
      return Status::Ok();
    } catch (const pqxx::sql_error& error) {
      Note(error);
      return MapSqlError(error);
    }
  }
  /// True when the transaction failed in a way that running it again may fix.
  bool retryable() const { return retryable_; }

 private:
  void Note(const pqxx::sql_error& error) {
    retryable_ = error.sqlstate() == "40001" || error.sqlstate() == "40P01";
  }

  PostgresDatabase& database_;
  PooledConnection& connection_;
  pqxx::work& work_;
  bool retryable_ = false;
};

class PostgresDatabase final : public SqlDatabase {
 public:
  PostgresDatabase(std::string url, int pool_size) : url_(std::move(url)), pool_size_(pool_size) {}

  Dialect dialect() const override { return Dialect::kPostgres; }

  Status InTransaction(TransactionMode /*mode*/,
                       const std::function<Status(SqlTransaction&)>& body) override {
    Status status;
    for (int attempt = 1; attempt <= kMaxAttempts; ++attempt) {
      ASSIGN_OR_RETURN(auto connection, Acquire());
      bool broken = false, retryable = false;
      try {
        pqxx::work work(*(connection)->connection);
        PostgresTransaction transaction(*this, *connection, work);
        status = body(transaction);
        retryable = transaction.retryable();
        if (status.ok())
          work.commit();
        else
          work.abort();
      } catch (const pqxx::broken_connection& error) {
        broken = true;
        status = Unavailable(std::string("postgresql connection lost: ") + error.what());
      } catch (const pqxx::in_doubt_error& error) {
        broken = true;
        status = Unavailable(std::string("postgresql commit outcome unknown: ") + error.what());
      } catch (const pqxx::sql_error& error) {
        retryable = error.sqlstate() == "40001" || error.sqlstate() == "40P01";
        status = MapSqlError(error);
      } catch (const std::exception& error) {
        status = Internal(std::string("postgresql: ") + error.what());
      }
      Release(std::move(connection), broken);
      if (status.ok() || !retryable) break;
    }
    return status;
  }

  /// The name under which `sql` is prepared on every connection.
  std::string StatementName(const std::string& sql) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto [it, inserted] = statement_names_.try_emplace(sql, "");
    if (inserted) it->second = std::string("s").append(std::to_string(statement_names_.size()));
    return it->second;
  }

  Result<std::unique_ptr<PooledConnection>> Acquire() {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      available_.wait(lock, [&] { return !idle_.empty() || open_ < pool_size_; });
      if (!idle_.empty()) {
        auto connection = std::move(idle_.back());
        idle_.pop_back();
        return connection;
      }
      ++open_;  // reserve the slot; connect outside the lock
    }
    try {
      auto pooled = std::make_unique<PooledConnection>();
      pooled->connection = std::make_unique<pqxx::connection>(url_);
      pqxx::nontransaction setup(*pooled->connection);
      setup.exec("SET client_min_messages TO warning");  // no NOTICE chatter on stderr
      setup.commit();
      return pooled;
    } catch (const std::exception& error) {
      std::lock_guard<std::mutex> lock(mutex_);
      --open_;
      available_.notify_one();
      return Unavailable(std::string("cannot connect to postgresql: ") + error.what());
    }
  }

  void Release(std::unique_ptr<PooledConnection> connection, bool broken) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (broken || !connection->connection->is_open()) {
      --open_;  // dropped; the next Acquire reconnects
    } else {
      idle_.push_back(std::move(connection));
    }
    available_.notify_one();
  }

 private:
  const std::string url_;
  const int pool_size_;
  std::mutex mutex_;  // guards idle_, open_ and statement_names_
  std::condition_variable available_;
  std::vector<std::unique_ptr<PooledConnection>> idle_;
  int open_ = 0;
  std::unordered_map<std::string, std::string> statement_names_;
};

std::string DoubleToText(double value) {
  char buffer[64];
  auto [end, error] = std::to_chars(buffer, buffer + sizeof(buffer), value);  // shortest round-trip form
  return error == std::errc() ? std::string(buffer, end) : "NaN";
}

Result<SqlRows> PostgresTransaction::Query(const std::string& sql, const std::vector<SqlValue>& params) {
  // Parameters travel as text: NULL as a null pointer, bytea in PostgreSQL's hex input form.
  std::vector<std::string> texts(params.size());
  std::vector<const char*> pointers(params.size(), nullptr);
  for (std::size_t i = 0; i < params.size(); ++i) {
    const SqlValue& value = params[i];
    if (std::holds_alternative<SqlNull>(value)) continue;
    if (auto* integer = std::get_if<std::int64_t>(&value)) {
      texts[i] = std::to_string(*integer);
    } else if (auto* real = std::get_if<double>(&value)) {
      texts[i] = DoubleToText(*real);
    } else if (auto* text = std::get_if<std::string>(&value)) {
      if (text->find('\0') != std::string::npos) return InvalidArgument("a text value contains a NUL byte");
      texts[i] = *text;
    } else {
      texts[i] = "\\x" + HexEncode(std::get<SqlBlob>(value).bytes);
    }
    pointers[i] = texts[i].c_str();
  }
  try {
    const std::string name = database_.StatementName(sql);
    if (connection_.prepared.insert(name).second) connection_.connection->prepare(name, sql);
    const pqxx::result result = work_.exec_prepared(name, pqxx::prepare::make_dynamic_params(pointers));
    SqlRows rows;
    rows.reserve(result.size());
    for (const pqxx::row& row : result) {
      std::vector<SqlValue> values;
      values.reserve(row.size());
      for (const pqxx::field& field : row) {
        if (field.is_null()) {
          values.emplace_back(SqlNull{});
          continue;
        }
        switch (field.type()) {
          case kByteaOid: values.emplace_back(SqlBlob{pqxx::binarystring(field).str()}); break;
          case kInt2Oid:
          case kInt4Oid:
          case kInt8Oid: values.emplace_back(field.as<std::int64_t>()); break;
          case kFloat4Oid:
          case kFloat8Oid:
          case kNumericOid: values.emplace_back(field.as<double>()); break;
          case kBoolOid: values.emplace_back(std::int64_t{field.as<bool>() ? 1 : 0}); break;
          default: values.emplace_back(std::string(field.c_str(), field.size()));
        }
      }
      rows.emplace_back(std::move(values));
    }
    return rows;
  } catch (const pqxx::sql_error& error) {
    Note(error);
    return MapSqlError(error);
  }
}

}  // namespace

Result<std::unique_ptr<SqlDatabase>> OpenPostgresDatabase(const std::string& connection_url, int pool_size) {
  auto database = std::make_unique<PostgresDatabase>(connection_url, pool_size);
  // Connect once now so a wrong URL or a down server is reported at open, not at first use.
  ASSIGN_OR_RETURN(auto connection, database->Acquire());
  database->Release(std::move(connection), /*broken=*/false);
  return std::unique_ptr<SqlDatabase>(std::move(database));
}

}  // namespace storage::internal
