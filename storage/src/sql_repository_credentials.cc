// SqlRepository: revoking and listing credentials, the credential epochs other processes poll, and the
// health probe's write.
#include "sql_repository.h"

namespace storage::internal {

Result<std::int64_t> NextCredentialEpoch(SqlTransaction& transaction) {
  ASSIGN_OR_RETURN(
      auto rows,
      transaction.Query("UPDATE credential_epoch SET epoch = epoch + 1 WHERE singleton = 1 RETURNING epoch",
                        {}));
  if (rows.empty()) return Internal("credential_epoch: its row is missing");
  return rows.front().Int(0);
}

Status SqlRepository::RevokeCredential(const std::string& principal) {
  RETURN_IF_ERROR(CheckText(principal, "principal", 256));
  return Write([&](SqlTransaction& transaction) -> Status {
    // The epoch first: its row lock serialises concurrent revocations, so two admins revoking each other at
    // once cannot both pass the last-admin check below.
    ASSIGN_OR_RETURN(auto epoch, NextCredentialEpoch(transaction));
    ASSIGN_OR_RETURN(
        auto rows, transaction.Query("SELECT algorithm FROM credentials WHERE principal = $1", {principal}));
    if (rows.empty()) return NotFound("no credential for " + principal);
    if (rows.front().Text(0) == kRevokedAlgorithm) return Status::Ok();
    if (principal.rfind("admin:", 0) == 0) {
      ASSIGN_OR_RETURN(
          auto others,
          transaction.Query(
              "SELECT COUNT(*) FROM credentials WHERE substr(principal, 1, 6) = 'admin:' AND principal <> $1 "
              "AND algorithm <> $2",
              {principal, std::string(kRevokedAlgorithm)}));
      if (others.front().Int(0) == 0) {
        return FailedPrecondition(principal +
                                  " is the last admin with a credential; mint another admin first");
      }
    }
    return transaction.Exec(
        "UPDATE credentials SET algorithm = $2, iterations = 0, salt = $3, hash = $3, updated_at_ms = $4, "
        "epoch = $5 WHERE principal = $1",
        {principal, std::string(kRevokedAlgorithm), SqlBlob{""}, NowMs(), epoch});
  });
}

Result<std::vector<CredentialRecord>> SqlRepository::ListCredentials(const std::string& prefix,
                                                                     const std::string& after, int limit,
                                                                     bool active_only) {
  if (limit < 1 || limit > 1000) return InvalidArgument("limit: expected 1..1000");
  RETURN_IF_ERROR(CheckText(prefix, "prefix", 256));
  RETURN_IF_ERROR(CheckText(after, "after", 256));
  std::vector<CredentialRecord> credentials;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(
            "SELECT principal, updated_at_ms, algorithm FROM credentials WHERE substr(principal, 1, $1) = $2 "
            "AND principal > $3 AND ($4 = 0 OR algorithm <> $5) ORDER BY principal LIMIT $6",
            {static_cast<std::int64_t>(prefix.size()), prefix, after, std::int64_t{active_only ? 1 : 0},
             std::string(kRevokedAlgorithm), std::int64_t{limit}}));
    for (const SqlRow& row : rows) {
      credentials.push_back(CredentialRecord{row.Text(0), row.Int(1), row.Text(2) == kRevokedAlgorithm});
    }
    return Status::Ok();
  }));
  return credentials;
}

Result<CredentialChanges> SqlRepository::CredentialChangesSince(std::int64_t since, int limit) {
  if (limit < 1 || limit > 100000) return InvalidArgument("limit: expected 1..100000");
  CredentialChanges changes;
  changes.epoch = since;
  // One statement, one snapshot: the counter and the changed rows are read together.
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows,
                     transaction.Query("SELECT e.epoch, c.principal, c.epoch FROM credential_epoch e LEFT "
                                       "JOIN (SELECT principal, epoch FROM "
                                       "credentials WHERE epoch > $1 ORDER BY epoch LIMIT $2) c ON 1 = 1 "
                                       "WHERE e.singleton = 1 ORDER BY c.epoch",
                                       {since, std::int64_t{limit}}));
    if (rows.empty()) return Internal("credential_epoch: its row is missing");
    const std::int64_t counter = rows.front().Int(0);
    if (since < 0) {
      changes.epoch = counter;
      return Status::Ok();
    }
    int changed = 0;
    for (const SqlRow& row : rows) {
      if (row.IsNull(1)) continue;
      changes.principals.push_back(row.Text(1));
      changes.epoch = std::max(changes.epoch, row.Int(2));
      ++changed;
    }
    changes.truncated = changed == limit;
    if (!changes.truncated && counter > changes.epoch) {
      // An epoch taken by a change that left no row: a credential erased with its robot (DeleteRobot). Which
      // principal is not known here, so the poller drops every cached token.
      changes.truncated = true;
      changes.epoch = counter;
    }
    return Status::Ok();
  }));
  return changes;
}

Status SqlRepository::ProbeWrite(const std::string& prober) {
  RETURN_IF_ERROR(CheckText(prober, "prober", 256));
  return Write([&](SqlTransaction& transaction) {
    return transaction.Exec(
        "INSERT INTO health_probe (singleton, prober, probed_at_ms) VALUES (1, $1, $2) ON CONFLICT "
        "(singleton) "
        "DO UPDATE SET prober = excluded.prober, probed_at_ms = excluded.probed_at_ms",
        {prober, NowMs()});
  });
}

void SqlRepository::NoteWriteFailure(const Status& status) {
  std::lock_guard lock(write_failure_mutex_);
  write_failure_ = WriteFailure{NowMs(), status.message()};
}

std::optional<WriteFailure> SqlRepository::LastWriteFailure() const {
  std::lock_guard lock(write_failure_mutex_);
  return write_failure_;
}

}  // namespace storage::internal
