// SQLite driver for SqlDatabase: one file, WAL journal, foreign keys on, a busy timeout, synchronous=FULL
// (an acknowledged upload survives power loss), and a cache of prepared statements.
//
// Thread safety: one connection guarded by a mutex held for a whole transaction. Other processes (or other
// SqliteDatabase objects) on the same file coordinate through SQLite's file locks and the busy timeout.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "sql_database.h"

namespace storage::internal {

/// Opens or creates the file. DATA_LOSS when it is not a SQLite database or is corrupt.
Result<std::unique_ptr<SqlDatabase>> OpenSqliteDatabase(const std::string& path,
                                                        std::chrono::milliseconds busy_timeout);

}  // namespace storage::internal
