// The few cryptographic helpers storage needs, over OpenSSL's libcrypto.
#pragma once

#include <cstdint>
#include <string>

namespace storage::internal {

/// Lowercase hex SHA-256 of bytes.
std::string Sha256Hex(const std::string& bytes);
/// `count` bytes from the OpenSSL CSPRNG.
std::string RandomBytes(std::size_t count);
std::string HexEncode(const std::string& bytes);

struct PasswordHash {
  std::string salt;  // random, 16 bytes
  std::string hash;  // PBKDF2-HMAC-SHA256 output, 32 bytes
  std::int64_t iterations = 0;
};

/// PBKDF2-HMAC-SHA256 with a fresh random salt (the legacy "pbkdf2-hmac-sha256" algorithm: still verified,
/// no longer written).
PasswordHash HashSecret(const std::string& secret);
/// Recomputes with the stored salt and iterations; compares in constant time.
bool VerifySecret(const std::string& secret, const PasswordHash& stored);

/// "salted-sha256": SHA-256(salt ‖ secret) with a fresh 16-byte salt, iterations 1. Enough for secrets of
/// 256 random bits (nothing to brute-force), and a microsecond to check, so checking costs an attacker as
/// much as it costs us.
PasswordHash HashTokenSecret(const std::string& secret);
/// Recomputes SHA-256(salt ‖ secret) and compares in constant time; false for a malformed record.
bool VerifyTokenSecret(const std::string& secret, const PasswordHash& stored);

}  // namespace storage::internal
