// Refusing weak secrets at start: the placeholder values shipped in deploy/ ("change-me", a local-trial
// default), anything that reads like one, and low-entropy strings. fleetd refuses to start with such a
// bootstrap admin token or database password instead of running with a secret everybody knows.
//
// Thread safety: pure functions.
#pragma once

#include <cstddef>
#include <string>

#include "slamcore/status.h"

namespace server {

/// OK, or INVALID_ARGUMENT naming `what` and the reason (the secret itself is never quoted): shorter than
/// `min_length`; containing a placeholder word (change-me, placeholder, example, secret, password, …);
/// a repetition of a shorter string ("abab…"); or below 80 bits by its character frequencies (length ×
/// Shannon entropy per character; 32 random hex characters score ≈ 110).
slamcore::Status CheckSecretStrength(const std::string& what, const std::string& secret,
                                     std::size_t min_length);

}  // namespace server
