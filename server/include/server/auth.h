// Authentication and authorisation of fleetd callers.
//
// Tokens are "<principal>.<secret>": the principal names the caller and its role ("robot:<id>",
// "engineer:<name>", "admin:<name>"), the secret is 32 random bytes in hex. Only a salted PBKDF2 hash of
// the secret is stored (storage::Repository::SetCredential). Because PBKDF2 is deliberately slow, a
// verified token is cached in memory (keyed by its SHA-256, never the token) for `cache_ttl`; replacing a
// credential through this Authenticator drops the principal's cached entries at once, other replicas
// notice within the TTL.
//
// Thread safety: Authenticator is safe to use from many threads (one internal mutex for the cache).
#pragma once

#include <chrono>
#include <cstdint>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "storage/repository.h"

namespace server {

enum class Role { kRobot, kEngineer, kAdmin };
const char* RoleName(Role role);  // "robot", "engineer", "admin"

/// What a caller wants to do; Allows() decides per role.
enum class Permission {
  kUpload,     // robots (own runs only), engineers, admins
  kRead,       // engineers, admins
  kReprocess,  // engineers, admins
  kLabel,      // engineers, admins
  kFetchMap,   // robots (own map only), engineers, admins: Maps.GetMap
  kRepairMap,  // engineers, admins: repair, approve and reject map versions
  kModels,     // admins: train and activate classifier models
  kAdmin,      // admins: credentials
};
const char* PermissionName(Permission permission);
bool Allows(Role role, Permission permission);

struct Principal {
  std::string name;  // "robot:r1"
  Role role = Role::kRobot;
  std::string id;    // "r1"
};

/// Parses and checks "robot:<id>" etc.; ids are 1..128 characters of [A-Za-z0-9_.-].
storage::Result<Principal> ParsePrincipal(const std::string& name);

/// 32 random bytes from the OS, as 64 hex characters.
std::string GenerateSecret();
std::string MakeToken(const std::string& principal, const std::string& secret);

/// Lowercase hex SHA-256.
std::string Sha256Hex(const std::string& bytes);

class Authenticator {
 public:
  Authenticator(storage::Repository& repository, std::chrono::seconds cache_ttl);

  enum class Outcome { kOk, kUnauthenticated, kUnavailable };
  struct Verdict {
    Outcome outcome = Outcome::kUnauthenticated;
    std::string message;
    Principal principal;
  };
  /// `authorization` is the metadata value, "Bearer <token>".
  Verdict Authenticate(const std::string& authorization);

  /// Stores a new secret for `principal` and returns the token.
  storage::Result<std::string> IssueToken(const Principal& principal);
  /// Stores a caller-chosen token (bootstrap admin from config); the token must be "<principal>.<secret>"
  /// with a secret of at least 32 characters.
  storage::Status InstallToken(const std::string& token);

 private:
  struct CacheEntry {
    Principal principal;
    std::chrono::steady_clock::time_point expires;
  };
  storage::Repository& repository_;
  const std::chrono::seconds cache_ttl_;
  std::mutex mutex_;  // guards cache_ and verifying_
  std::condition_variable verifying_cv_;
  std::unordered_map<std::string, CacheEntry> cache_;  // key: SHA-256 of the token
  std::unordered_set<std::string> verifying_;          // keys being verified right now
};

/// Per-principal token buckets: `rate` requests per second with bursts of `burst`. rate <= 0: unlimited.
class RateLimiter {
 public:
  RateLimiter(double rate, double burst) : rate_(rate), burst_(burst) {}
  /// Takes one token; false when the bucket is empty.
  bool Allow(const std::string& key);

 private:
  struct Bucket {
    double tokens = 0.0;
    std::chrono::steady_clock::time_point last;
  };
  const double rate_, burst_;
  std::mutex mutex_;  // guards buckets_
  std::unordered_map<std::string, Bucket> buckets_;
};

}  // namespace server
