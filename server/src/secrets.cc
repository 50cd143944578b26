#include "server/secrets.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>

namespace server {
namespace {

constexpr double kMinimumBits = 80.0;

// Lowercase, with '-', '_' and '.' removed: "Change_Me" and "change-me" read the same.
std::string Folded(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '-' || c == '_' || c == '.') continue;
    out.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  return out;
}

bool IsRepetition(const std::string& text) {
  for (std::size_t period = 1; period <= text.size() / 2; ++period) {
    if (text.size() % period != 0) continue;
    bool repeats = true;
    for (std::size_t i = period; i < text.size() && repeats; ++i) repeats = text[i] == text[i - period];
    if (repeats) return true;
  }
  return false;
}

double EntropyBits(const std::string& text) {
  std::array<int, 256> counts{};
  for (char c : text) ++counts[static_cast<unsigned char>(c)];
  double bits = 0.0;
  for (int count : counts) {
    if (count == 0) continue;
    const double p = static_cast<double>(count) / static_cast<double>(text.size());
    bits -= static_cast<double>(count) * std::log2(p);
  }
  return bits;
}

}  // namespace

slamcore::Status CheckSecretStrength(const std::string& what, const std::string& secret,
                                     std::size_t min_length) {
  static const char* kPlaceholders[] = {"changeme",   "placeholder", "example",  "replace", "secret",
                                        "password",   "passwd",      "default",  "sample",  "dummy",
                                        "localtrial", "fleetlocal",  "insecure", "xxxx"};
  const std::string folded = Folded(secret);
  for (const char* word : kPlaceholders) {
    if (folded.find(word) != std::string::npos) {
      return slamcore::InvalidArgument(what + ": looks like a placeholder (contains \"" + std::string(word) +
                                       "\"); replace it with a random value, e.g. `openssl rand -hex 32`");
    }
  }
  if (secret.size() < min_length) {
    return slamcore::InvalidArgument(what + ": shorter than " + std::to_string(min_length) +
                                     " characters; generate one, e.g. `openssl rand -hex 32`");
  }
  if (IsRepetition(secret)) {
    return slamcore::InvalidArgument(what +
                                     ": a repetition of a shorter string (low entropy); use a random value");
  }
  if (const double bits = EntropyBits(secret); bits < kMinimumBits) {
    return slamcore::InvalidArgument(what + ": low entropy (" + std::to_string(static_cast<int>(bits)) +
                                     " bits by character frequencies, at least " +
                                     std::to_string(static_cast<int>(kMinimumBits)) +
                                     " needed); use a random value");
  }
  return slamcore::Status::Ok();
}

}  // namespace server
