#include "server/auth.h"

#include "server/secrets.h"

#include <openssl/rand.h>
#include <openssl/sha.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

namespace server {
namespace {

std::string Hex(const unsigned char* data, std::size_t size) {
  static const char* kDigits = "0123456789abcdef";
  std::string out;
  out.reserve(size * 2);
  for (std::size_t i = 0; i < size; ++i) {
    out.push_back(kDigits[data[i] >> 4]);
    out.push_back(kDigits[data[i] & 15]);
  }
  return out;
}

bool ValidId(const std::string& id) {
  if (id.empty() || id.size() > 128) return false;
  return std::all_of(id.begin(), id.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
}

}  // namespace

const char* RoleName(Role role) {
  switch (role) {
    case Role::kRobot: return "robot";
    case Role::kEngineer: return "engineer";
    case Role::kAdmin: return "admin";
  }
  return "unknown";
}

const char* PermissionName(Permission permission) {
  switch (permission) {
    case Permission::kUpload: return "upload";
    case Permission::kRead: return "read";
    case Permission::kReprocess: return "reprocess";
    case Permission::kLabel: return "label";
    case Permission::kFetchMap: return "fetch_map";
    case Permission::kRepairMap: return "repair_map";
    case Permission::kModels: return "models";
    case Permission::kAdmin: return "admin";
    case Permission::kRotateOwn: return "rotate_own";
  }
  return "unknown";
}

bool Allows(Role role, Permission permission) {
  if (permission == Permission::kRotateOwn) return true;
  switch (role) {
    case Role::kAdmin: return true;
    case Role::kEngineer: return permission != Permission::kModels && permission != Permission::kAdmin;
    case Role::kRobot: return permission == Permission::kUpload || permission == Permission::kFetchMap;
  }
  return false;
}

slamcore::Result<Principal> ParsePrincipal(const std::string& name) {
  const std::size_t colon = name.find(':');
  if (colon == std::string::npos) {
    return slamcore::InvalidArgument(
        "principal: expected \"robot:<id>\", \"engineer:<name>\" or \"admin:<name>\"");
  }
  const std::string kind = name.substr(0, colon), id = name.substr(colon + 1);
  Principal principal;
  principal.name = name;
  principal.id = id;
  if (kind == "robot") {
    principal.role = Role::kRobot;
  } else if (kind == "engineer") {
    principal.role = Role::kEngineer;
  } else if (kind == "admin") {
    principal.role = Role::kAdmin;
  } else {
    return slamcore::InvalidArgument("principal: unknown role \"" + kind + "\" (robot, engineer or admin)");
  }
  if (!ValidId(id))
    return slamcore::InvalidArgument("principal: id must be 1-128 characters of [A-Za-z0-9_.-]");
  return principal;
}

std::string GenerateSecret() {
  unsigned char bytes[32];
  if (RAND_bytes(bytes, sizeof bytes) != 1) {
    // RAND_bytes only fails when the OS has no entropy source; refuse to mint a weak secret.
    std::fprintf(stderr, "fleetd: RAND_bytes failed\n");
    std::abort();
  }
  return Hex(bytes, sizeof bytes);
}

std::string MakeToken(const std::string& principal, const std::string& secret) {
  return principal + "." + secret;
}

std::string Sha256Hex(const std::string& bytes) {
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), digest);
  return Hex(digest, sizeof digest);
}

Authenticator::Authenticator(storage::Repository& repository, std::chrono::seconds cache_ttl,
                             std::chrono::milliseconds revocation_poll)
    : repository_(repository), cache_ttl_(cache_ttl), revocation_poll_(revocation_poll) {}

void Authenticator::DropCachedLocked(const std::string& principal) {
  for (auto it = cache_.begin(); it != cache_.end();) {
    if (it->second.principal.name == principal) {
      recency_.erase(it->second.recency);
      it = cache_.erase(it);
    } else {
      ++it;
    }
  }
}

void Authenticator::RefreshRevocations(std::chrono::steady_clock::time_point now) {
  std::int64_t since = 0;
  {
    std::lock_guard lock(mutex_);
    if (polling_ || now < next_poll_) return;
    polling_ = true;  // one poll at a time; the other callers use the cache as it is
    since = credential_epoch_;
  }
  constexpr int kMaxChanges = 1000;
  auto changes = repository_.CredentialChangesSince(since, kMaxChanges);
  std::lock_guard lock(mutex_);
  polling_ = false;
  next_poll_ = now + revocation_poll_;
  if (!changes.ok()) return;  // retried at the next interval; entries still expire by their TTL
  // Many changes at once, or the first successful poll (what was cached before it, while polls failed, may
  // predate a change the newest epoch already covers): start over.
  if (changes->truncated || since < 0) {
    cache_.clear();
    recency_.clear();
  } else {
    for (const std::string& principal : changes->principals) DropCachedLocked(principal);
  }
  credential_epoch_ = changes->epoch;
}

std::optional<Principal> Authenticator::CachedLocked(const std::string& key,
                                                     std::chrono::steady_clock::time_point now) {
  auto it = cache_.find(key);
  if (it == cache_.end()) return std::nullopt;
  if (it->second.expires <= now) {
    recency_.erase(it->second.recency);
    cache_.erase(it);
    return std::nullopt;
  }
  recency_.splice(recency_.begin(), recency_, it->second.recency);
  return it->second.principal;
}

void Authenticator::CacheLocked(const std::string& key, const Principal& principal,
                                std::chrono::steady_clock::time_point now) {
  if (auto it = cache_.find(key); it != cache_.end()) {
    recency_.erase(it->second.recency);
    cache_.erase(it);
  }
  recency_.push_front(key);
  cache_[key] = CacheEntry{principal, now + cache_ttl_, recency_.begin()};
  while (cache_.size() > kCacheCapacity) {
    cache_.erase(recency_.back());
    recency_.pop_back();
  }
}

double Authenticator::LockedForLocked(const std::string& key, std::chrono::steady_clock::time_point now) {
  auto it = failures_.find(key);
  if (it == failures_.end()) return 0.0;
  FailureBucket& bucket = it->second;
  const double elapsed = std::chrono::duration<double>(now - bucket.last).count();
  bucket.failures = std::max(0.0, bucket.failures - elapsed / kFailureRefillSeconds);
  bucket.last = now;
  if (bucket.failures <= 0.0) {
    failures_.erase(it);
    return 0.0;
  }
  if (bucket.locked && bucket.failures <= kFailuresKeptAtUnlock) bucket.locked = false;
  return bucket.locked ? (bucket.failures - kFailuresKeptAtUnlock) * kFailureRefillSeconds : 0.0;
}

void Authenticator::RecordFailureLocked(const std::string& key, std::chrono::steady_clock::time_point now) {
  if (failures_.size() > 100000) failures_.clear();  // bound memory against spraying many names
  LockedForLocked(key, now);                         // decays the earlier failures first
  FailureBucket& bucket = failures_[key];
  bucket.failures += 1.0;
  bucket.last = now;
  // The kFailureBurst-th failure in quick succession locks (the earlier ones have decayed a little).
  if (bucket.failures > kFailureBurst - 1.0) bucket.locked = true;
}

Authenticator::Verdict Authenticator::Authenticate(const std::string& authorization,
                                                   const std::string& peer) {
  Verdict verdict;
  static const std::string kBearer = "Bearer ";
  if (authorization.empty()) {
    verdict.message = "authorization: missing; send \"authorization: Bearer <token>\"";
    return verdict;
  }
  if (authorization.rfind(kBearer, 0) != 0) {
    verdict.message = "authorization: expected \"Bearer <token>\"";
    return verdict;
  }
  const std::string token = authorization.substr(kBearer.size());
  const std::size_t dot = token.rfind('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == token.size() || token.size() > 512) {
    verdict.message = "authorization: malformed token (expected <principal>.<secret>)";
    return verdict;
  }
  const std::string key = Sha256Hex(token);
  const std::string peer_key = peer.empty() ? "" : "peer:" + peer;
  auto now = std::chrono::steady_clock::now();
  RefreshRevocations(now);
  {
    std::lock_guard lock(mutex_);
    if (auto cached = CachedLocked(key, now)) {
      verdict.outcome = Outcome::kOk;
      verdict.principal = std::move(*cached);
      return verdict;
    }
  }
  auto principal = ParsePrincipal(token.substr(0, dot));
  if (!principal.ok()) {
    verdict.message = "authorization: token names an invalid principal";
    return verdict;
  }
  const std::string principal_key = "principal:" + principal->name;
  {
    std::lock_guard lock(mutex_);
    const double locked_for = std::max(LockedForLocked(principal_key, now),
                                       peer_key.empty() ? 0.0 : LockedForLocked(peer_key, now));
    if (locked_for > 0.0) {
      verdict.message = "authorization: too many failed attempts for " + principal->name +
                        " or from this address; retry in " +
                        std::to_string(static_cast<int>(std::ceil(locked_for))) + " s";
      return verdict;
    }
  }
  auto verified = repository_.VerifyCredential(principal->name, token.substr(dot + 1));
  if (!verified.ok()) {
    verdict.outcome = Outcome::kUnavailable;
    verdict.message = "credential store: " + verified.status().message();
    return verdict;
  }
  now = std::chrono::steady_clock::now();
  std::lock_guard lock(mutex_);
  if (!*verified) {
    RecordFailureLocked(principal_key, now);
    if (!peer_key.empty()) RecordFailureLocked(peer_key, now);
    verdict.message = "authorization: invalid token for " + principal->name;
    return verdict;
  }
  CacheLocked(key, *principal, now);
  verdict.outcome = Outcome::kOk;
  verdict.principal = std::move(principal).value();
  return verdict;
}

slamcore::Result<std::string> Authenticator::IssueToken(const Principal& principal) {
  const std::string secret = GenerateSecret();
  RETURN_IF_ERROR(repository_.SetCredential(principal.name, secret));
  ForgetPrincipal(principal.name);
  return MakeToken(principal.name, secret);
}

void Authenticator::ForgetPrincipal(const std::string& name) {
  std::lock_guard lock(mutex_);
  DropCachedLocked(name);
}

slamcore::Result<std::string> Authenticator::RotateToken(const Principal& principal) {
  ASSIGN_OR_RETURN(auto existing, repository_.ListCredentials(principal.name, "", 1, /*active_only=*/true));
  if (existing.empty() || existing.front().principal != principal.name) {
    return slamcore::NotFound("no unrevoked credential for " + principal.name +
                              "; mint one with SetCredential");
  }
  return IssueToken(principal);
}

slamcore::Status Authenticator::RevokeToken(const Principal& principal) {
  RETURN_IF_ERROR(repository_.RevokeCredential(principal.name));
  ForgetPrincipal(principal.name);
  return slamcore::Status::Ok();
}

slamcore::Result<Authenticator::BootstrapOutcome> Authenticator::InstallBootstrapToken(
    const std::string& token, bool force) {
  const std::size_t dot = token.rfind('.');
  if (dot == std::string::npos) {
    return slamcore::InvalidArgument("bootstrap_admin_token: expected admin:<name>.<secret>");
  }
  auto principal = ParsePrincipal(token.substr(0, dot));
  if (!principal.ok())
    return slamcore::InvalidArgument("bootstrap_admin_token: " + principal.status().message());
  if (principal->role != Role::kAdmin) {
    return slamcore::InvalidArgument("bootstrap_admin_token: names " + principal->name +
                                     ", not an admin (admin:<name>.<secret>)");
  }
  const std::string secret = token.substr(dot + 1);
  RETURN_IF_ERROR(CheckSecretStrength("bootstrap_admin_token", secret, 32));
  ASSIGN_OR_RETURN(auto verified, repository_.VerifyCredential(principal->name, secret));
  if (verified) return BootstrapOutcome::kAlreadyValid;
  if (!force) {
    ASSIGN_OR_RETURN(auto admins, repository_.ListCredentials("admin:", "", 1, /*active_only=*/true));
    if (!admins.empty()) return BootstrapOutcome::kSkippedAdminExists;
  }
  RETURN_IF_ERROR(repository_.SetCredential(principal->name, secret));
  return BootstrapOutcome::kInstalled;
}

bool RateLimiter::Allow(const std::string& key) {
  if (rate_ <= 0) return true;
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard lock(mutex_);
  auto [it, inserted] = buckets_.try_emplace(key);
  Bucket& bucket = it->second;
  if (inserted) {
    bucket.tokens = burst_;
  } else {
    const double elapsed = std::chrono::duration<double>(now - bucket.last).count();
    bucket.tokens = std::min(burst_, bucket.tokens + elapsed * rate_);
  }
  bucket.last = now;
  if (bucket.tokens < 1.0) return false;
  bucket.tokens -= 1.0;
  return true;
}

}  // namespace server
