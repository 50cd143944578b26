#include "open_repository.h"

#include "migrations.h"
#include "postgres_database.h"
#include "sqlite_database.h"

namespace storage {
namespace internal {
namespace {

bool StartsWith(const std::string& text, const std::string& prefix) { return text.rfind(prefix, 0) == 0; }

}  // namespace

Result<std::unique_ptr<SqlRepository>> OpenSqlRepository(const std::string& url, const OpenOptions& options) {
  Result<std::unique_ptr<SqlDatabase>> database = InvalidArgument(
      "unknown database URL '" + url + "': expected sqlite:PATH or postgresql://...");
  if (StartsWith(url, "sqlite:")) {
    database = OpenSqliteDatabase(url.substr(std::string("sqlite:").size()), options.sqlite_busy_timeout);
  } else if (StartsWith(url, "postgresql://") || StartsWith(url, "postgres://")) {
    if (options.postgres_pool_size < 1) return InvalidArgument("postgres_pool_size must be at least 1");
    database = OpenPostgresDatabase(url, options.postgres_pool_size);
  }
  if (!database.ok()) return database.status();
  STORAGE_RETURN_IF_ERROR(MigrateToLatest(**database));
  return std::make_unique<SqlRepository>(std::move(database).value());
}

}  // namespace internal

std::int64_t LatestSchemaVersion() { return internal::LatestSchemaVersionInternal(); }

Result<std::unique_ptr<Repository>> OpenRepository(const std::string& url, const OpenOptions& options) {
  auto repository = internal::OpenSqlRepository(url, options);
  if (!repository.ok()) return repository.status();
  return std::unique_ptr<Repository>(std::move(repository).value());
}

}  // namespace storage
