// Internal: open a SqlRepository (tests use it for the fault hook and raw SQL access).
#pragma once

#include "sql_repository.h"

namespace storage::internal {

Result<std::unique_ptr<SqlRepository>> OpenSqlRepository(const std::string& url, const OpenOptions& options);

}  // namespace storage::internal
