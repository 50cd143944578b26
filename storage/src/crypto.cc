#include "crypto.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>

#include <stdexcept>

namespace storage::internal {
namespace {

// OWASP's 2023 figure for PBKDF2-HMAC-SHA256 is 600k; verification happens once per connection (robots
// authenticate a session), so the cost (~0.2 s on one core) is paid rarely.
constexpr std::int64_t kPbkdf2Iterations = 600000;
constexpr std::size_t kSaltBytes = 16;
constexpr std::size_t kHashBytes = 32;

std::string Pbkdf2(const std::string& secret, const std::string& salt, std::int64_t iterations) {
  std::string out(kHashBytes, '\0');
  if (PKCS5_PBKDF2_HMAC(secret.data(), static_cast<int>(secret.size()),
                        reinterpret_cast<const unsigned char*>(salt.data()), static_cast<int>(salt.size()),
                        static_cast<int>(iterations), EVP_sha256(), static_cast<int>(out.size()),
                        reinterpret_cast<unsigned char*>(out.data())) != 1) {
    throw std::runtime_error("PKCS5_PBKDF2_HMAC failed");
  }
  return out;
}

}  // namespace

std::string HexEncode(const std::string& bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(bytes.size() * 2);
  for (unsigned char c : bytes) {
    out.push_back(kDigits[c >> 4]);
    out.push_back(kDigits[c & 0xF]);
  }
  return out;
}

std::string Sha256Hex(const std::string& bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &length, EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("EVP_Digest(SHA-256) failed");
  }
  return HexEncode(std::string(reinterpret_cast<const char*>(digest), length));
}

std::string RandomBytes(std::size_t count) {
  std::string out(count, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(out.data()), static_cast<int>(count)) != 1) {
    throw std::runtime_error("RAND_bytes failed");
  }
  return out;
}

PasswordHash HashSecret(const std::string& secret) {
  PasswordHash out;
  out.salt = RandomBytes(kSaltBytes);
  out.iterations = kPbkdf2Iterations;
  out.hash = Pbkdf2(secret, out.salt, out.iterations);
  return out;
}

bool VerifySecret(const std::string& secret, const PasswordHash& stored) {
  if (stored.iterations <= 0 || stored.iterations > 10'000'000 || stored.hash.size() != kHashBytes)
    return false;
  const std::string computed = Pbkdf2(secret, stored.salt, stored.iterations);
  return CRYPTO_memcmp(computed.data(), stored.hash.data(), kHashBytes) == 0;
}

PasswordHash HashTokenSecret(const std::string& secret) {
  PasswordHash out;
  out.salt = RandomBytes(kSaltBytes);
  out.iterations = 1;
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  const std::string salted = out.salt + secret;
  if (EVP_Digest(salted.data(), salted.size(), digest, &length, EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("EVP_Digest(SHA-256) failed");
  }
  out.hash.assign(reinterpret_cast<const char*>(digest), length);
  return out;
}

bool VerifyTokenSecret(const std::string& secret, const PasswordHash& stored) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  const std::string salted = stored.salt + secret;
  if (EVP_Digest(salted.data(), salted.size(), digest, &length, EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("EVP_Digest(SHA-256) failed");
  }
  if (stored.hash.size() != length) return false;
  return CRYPTO_memcmp(digest, stored.hash.data(), length) == 0;
}

}  // namespace storage::internal
