// Authentication and authorisation of fleetd callers.
//
// Tokens are "<principal>.<secret>": the principal names the caller and its role ("robot:<id>",
// "engineer:<name>", "admin:<name>"), the secret is 32 random bytes in hex. Only a salted SHA-256 of the
// secret is stored (storage::Repository::SetCredential): with 256 random bits there is nothing to
// brute-force, so checking is as cheap for us as guessing is for an attacker.
//
// Order of a check, cheapest first: the header's shape; an LRU of verified tokens (keyed by the token's
// SHA-256, never the token; entries live `cache_ttl`); the principal's syntax; failed-attempt limits per
// principal and per peer, which refuse before any lookup or hashing (kFailureBurst failures lock the key
// until all but kFailuresKeptAtUnlock have decayed at one per kFailureRefillSeconds, so at most one guess a
// second in the long run, and a refusal says how long the lock still holds); then the credential store.
// Unknown principals cost the store the same hash as known ones. A token already verified keeps working while
// its principal is under attack (the LRU answers first). Replacing or revoking a credential through this
// Authenticator drops the principal's cached entries at once; every other process sharing the database drops
// them at its next poll of the credential epochs (storage::Repository::CredentialChangesSince, at most every
// `revocation_poll`, default 1 s, done by the first call after the interval), so a revoked or rotated token
// is refused everywhere within about a second. While the poll fails (database unreachable) cached entries
// still end after `cache_ttl`.
//
// Thread safety: Authenticator is safe to use from many threads (one internal mutex for the cache).
#pragma once

#include <chrono>
#include <cstdint>
#include <list>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

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
  kRotateOwn,  // everyone: a new secret for its own token (Admin.RotateCredential of itself)
};
const char* PermissionName(Permission permission);
bool Allows(Role role, Permission permission);

struct Principal {
  std::string name;  // "robot:r1"
  Role role = Role::kRobot;
  std::string id;  // "r1"
};

/// Parses and checks "robot:<id>" etc.; ids are 1..128 characters of [A-Za-z0-9_.-].
slamcore::Result<Principal> ParsePrincipal(const std::string& name);

/// 32 random bytes from the OS, as 64 hex characters.
std::string GenerateSecret();
std::string MakeToken(const std::string& principal, const std::string& secret);

/// Lowercase hex SHA-256.
std::string Sha256Hex(const std::string& bytes);

class Authenticator {
 public:
  Authenticator(storage::Repository& repository, std::chrono::seconds cache_ttl,
                std::chrono::milliseconds revocation_poll = std::chrono::milliseconds(1000));

  enum class Outcome { kOk, kUnauthenticated, kUnavailable };
  struct Verdict {
    Outcome outcome = Outcome::kUnauthenticated;
    std::string message;
    Principal principal;
  };
  /// `authorization` is the metadata value, "Bearer <token>"; `peer` the caller's address without port
  /// (empty: no per-peer limit).
  Verdict Authenticate(const std::string& authorization, const std::string& peer = "");

  static constexpr double kFailureBurst = 20.0;
  static constexpr double kFailuresKeptAtUnlock = 10.0;
  static constexpr double kFailureRefillSeconds = 1.0;
  static constexpr std::size_t kCacheCapacity = 10000;

  /// Stores a new secret for `principal` and returns the token.
  slamcore::Result<std::string> IssueToken(const Principal& principal);
  /// A new secret for a principal that has an unrevoked credential (NOT_FOUND otherwise); the old token
  /// is refused from now on.
  slamcore::Result<std::string> RotateToken(const Principal& principal);
  /// Revokes the principal's token (storage::Repository::RevokeCredential's errors).
  slamcore::Status RevokeToken(const Principal& principal);

  enum class BootstrapOutcome { kInstalled, kAlreadyValid, kSkippedAdminExists };
  /// The bootstrap admin token from config: "admin:<name>.<secret>" with a strong secret (server/secrets.h).
  /// Installed only while no admin has an unrevoked credential, so a rotation or revocation survives
  /// restarts; `force` installs it anyway (the operator's explicit recovery).
  slamcore::Result<BootstrapOutcome> InstallBootstrapToken(const std::string& token, bool force);
  /// Drops the principal's verified tokens from this process's cache (its credential was replaced, revoked
  /// or erased); other processes drop them when they poll the credential epochs.
  void ForgetPrincipal(const std::string& name);

 private:
  struct CacheEntry {
    Principal principal;
    std::chrono::steady_clock::time_point expires;
    std::list<std::string>::iterator recency;
  };
  struct FailureBucket {
    double failures = 0.0;
    bool locked = false;  // reached kFailureBurst and not yet decayed to kFailuresKeptAtUnlock
    std::chrono::steady_clock::time_point last;
  };
  std::optional<Principal> CachedLocked(const std::string& key, std::chrono::steady_clock::time_point now);
  void CacheLocked(const std::string& key, const Principal& principal,
                   std::chrono::steady_clock::time_point now);
  /// Seconds until `key` may try again, 0 when it may now (decays its failures first). A lock ends only
  /// once failures decay to kFailuresKeptAtUnlock: a bucket hovering at the burst would let every caller
  /// from a flooding address through a moment after each refill, which nobody could rely on.
  double LockedForLocked(const std::string& key, std::chrono::steady_clock::time_point now);
  void RecordFailureLocked(const std::string& key, std::chrono::steady_clock::time_point now);
  void DropCachedLocked(const std::string& principal);
  /// Polls the credential epochs when due and drops the cached tokens of changed principals.
  void RefreshRevocations(std::chrono::steady_clock::time_point now);

  storage::Repository& repository_;
  const std::chrono::seconds cache_ttl_;
  const std::chrono::milliseconds revocation_poll_;
  std::mutex mutex_;                    // guards cache_, recency_, failures_, the poll state below
  std::int64_t credential_epoch_ = -1;  // -1: not polled yet (the first poll only reads the newest epoch)
  bool polling_ = false;
  std::chrono::steady_clock::time_point next_poll_{};
  std::unordered_map<std::string, CacheEntry> cache_;        // key: SHA-256 of the token
  std::list<std::string> recency_;                           // cache keys, most recently used first
  std::unordered_map<std::string, FailureBucket> failures_;  // "principal:<name>" and "peer:<address>"
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
