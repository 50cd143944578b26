#include "open_repository.h"

#include <cctype>
#include <utility>

#include "migrations.h"
#include "postgres_database.h"
#include "sqlite_database.h"

namespace storage {
namespace internal {
namespace {

bool StartsWith(const std::string& text, const std::string& prefix) { return text.rfind(prefix, 0) == 0; }

bool IsPostgresUrl(const std::string& url) {
  return StartsWith(url, "postgresql://") || StartsWith(url, "postgres://");
}

/// [begin, end) of the password in "scheme://user:password@host...", or {npos, npos}.
std::pair<std::size_t, std::size_t> PasswordSpan(const std::string& url) {
  const std::size_t authority = url.find("://");
  if (authority == std::string::npos) return {std::string::npos, std::string::npos};
  const std::size_t start = authority + 3;
  const std::size_t end_of_authority = url.find_first_of("/?", start);
  const std::size_t at =
      url.rfind('@', end_of_authority == std::string::npos ? url.size() : end_of_authority);
  if (at == std::string::npos || at < start) return {std::string::npos, std::string::npos};
  const std::size_t colon = url.find(':', start);
  if (colon == std::string::npos || colon > at) return {std::string::npos, std::string::npos};
  return {colon + 1, at};
}

/// The value of "password=" among the URL's query parameters, as written.
std::pair<std::size_t, std::size_t> QueryPasswordSpan(const std::string& url) {
  const std::size_t query = url.find('?');
  if (query == std::string::npos) return {std::string::npos, std::string::npos};
  for (std::size_t at = query + 1; at < url.size();) {
    std::size_t end = url.find('&', at);
    if (end == std::string::npos) end = url.size();
    if (url.compare(at, 9, "password=") == 0) return {at + 9, end};
    at = end + 1;
  }
  return {std::string::npos, std::string::npos};
}

std::string PercentDecoded(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '%' && i + 2 < text.size() && std::isxdigit(static_cast<unsigned char>(text[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(text[i + 2]))) {
      out.push_back(static_cast<char>(std::stoi(text.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else {
      out.push_back(text[i]);
    }
  }
  return out;
}

/// `status` with every spelling of the URL's password replaced by "***".
Status Scrubbed(const Status& status, const std::string& url) {
  std::string message = status.message();
  for (const std::string& password : DatabaseUrlPasswords(url)) {
    for (std::size_t at = message.find(password); at != std::string::npos;
         at = message.find(password, at + 3)) {
      message.replace(at, password.size(), "***");
    }
  }
  return Status(status.code(), message);
}

}  // namespace

Result<std::unique_ptr<SqlRepository>> OpenSqlRepository(const std::string& url, const OpenOptions& options) {
  Result<std::unique_ptr<SqlDatabase>> database = InvalidArgument(
      "unknown database URL '" + RedactDatabaseUrl(url) + "': expected sqlite:PATH or postgresql://...");
  if (StartsWith(url, "sqlite:")) {
    database = OpenSqliteDatabase(url.substr(std::string("sqlite:").size()), options.sqlite_busy_timeout);
  } else if (IsPostgresUrl(url)) {
    if (options.postgres_pool_size < 1) return InvalidArgument("postgres_pool_size must be at least 1");
    database = OpenPostgresDatabase(url, options.postgres_pool_size);
  }
  RETURN_IF_ERROR(database.status());
  RETURN_IF_ERROR(MigrateToLatest(**database));
  return std::make_unique<SqlRepository>(std::move(database).value());
}

}  // namespace internal

std::int64_t LatestSchemaVersion() { return internal::LatestSchemaVersionInternal(); }

std::string RedactDatabaseUrl(const std::string& url) {
  std::string out = url;
  for (auto span : {internal::QueryPasswordSpan(out), internal::PasswordSpan(out)}) {
    if (span.first != std::string::npos) out.replace(span.first, span.second - span.first, "***");
  }
  return out;
}

std::vector<std::string> DatabaseUrlPasswords(const std::string& url) {
  std::vector<std::string> passwords;
  for (auto span : {internal::PasswordSpan(url), internal::QueryPasswordSpan(url)}) {
    if (span.first == std::string::npos || span.second <= span.first) continue;
    const std::string written = url.substr(span.first, span.second - span.first);
    passwords.push_back(written);
    if (const std::string decoded = internal::PercentDecoded(written); decoded != written)
      passwords.push_back(decoded);
  }
  return passwords;
}

Result<std::unique_ptr<Repository>> OpenRepository(const std::string& url, const OpenOptions& options) {
  auto repository = internal::OpenSqlRepository(url, options);
  if (!repository.ok()) return internal::Scrubbed(repository.status(), url);
  return std::unique_ptr<Repository>(std::move(repository).value());
}

}  // namespace storage
