// Versioned schema migrations, applied in order at open inside one transaction. The schema itself is
// described in storage/docs/schema.md. A database whose version is newer than kMigrations.size() was
// written by a newer program and is refused rather than misread.
#pragma once

#include <cstdint>

#include "sql_database.h"

namespace storage::internal {

std::int64_t LatestSchemaVersionInternal();

/// Creates schema_version when missing, refuses a newer schema, applies the missing migrations.
Status MigrateToLatest(SqlDatabase& database);
/// The same up to `target_version` only (tests of upgrades from an older schema).
Status MigrateTo(SqlDatabase& database, std::int64_t target_version);

/// MAX(version) from schema_version (0 when empty).
Result<std::int64_t> ReadSchemaVersion(SqlTransaction& transaction);

}  // namespace storage::internal
