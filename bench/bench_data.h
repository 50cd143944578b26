// Where the benchmarks find their data: the repository's data/ first, else the larger set beside it, as the
// tests do (tests/support/test_data.h).
#pragma once

#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

#include "test_data.h"

namespace bench {

/// The data file `relative` (e.g. "posegraphs/vertigo/intel.g2o"), or nullopt after saying on stderr, as
/// `program`, which file is missing and where it would be.
inline std::optional<std::filesystem::path> FindData(const char* program, const std::string& relative) {
  if (std::optional<std::filesystem::path> found = test_data::Find(relative)) return found;
  std::fprintf(stderr, "%s: %s\n", program, test_data::NeedsLargerSet(relative).c_str());
  return std::nullopt;
}

}  // namespace bench
