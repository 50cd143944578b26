// PostgreSQL driver for SqlDatabase over libpqxx 6.4: a pool of connections, each statement prepared once
// per connection and executed with bound parameters (text format; bytea as hex).
//
// Thread safety: InTransaction borrows one pooled connection for the whole transaction; the pool is guarded
// by a mutex and waits when all connections are busy.
#pragma once

#include <memory>
#include <string>

#include "sql_database.h"

namespace storage::internal {

/// `connection_url` is a libpq URL or key=value string. UNAVAILABLE when the server cannot be reached.
Result<std::unique_ptr<SqlDatabase>> OpenPostgresDatabase(const std::string& connection_url, int pool_size);

}  // namespace storage::internal
