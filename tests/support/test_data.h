// Where tests find their data. The repository's data/ comes first (a small licensed sample, see
// data/NOTICE.md); the optional larger set of the same layout beside the repository (CMake's
// SHARED_DATA_DIR, by default ../shared/data) second. A test that needs a file neither holds skips with the
// reason, so a fresh clone runs every test it can and shows the rest as skipped, never as passed.
//
// Thread safety: free functions without shared state.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <system_error>

namespace test_data {

/// data/ in the repository.
inline std::filesystem::path Sample() { return SAMPLE_DATA_DIR; }

/// The larger data set, or nullopt when it is not there.
inline std::optional<std::filesystem::path> Larger() {
  std::error_code error;
  const std::filesystem::path dir(SHARED_DATA_DIR);
  if (std::filesystem::is_directory(dir, error)) return dir;
  return std::nullopt;
}

/// `relative` (e.g. "posegraphs/vertigo/ring.g2o") in data/, else in the larger set; nullopt when neither
/// holds it.
inline std::optional<std::filesystem::path> Find(const std::string& relative) {
  std::error_code error;
  if (std::filesystem::exists(Sample() / relative, error)) return Sample() / relative;
  if (const auto larger = Larger(); larger && std::filesystem::exists(*larger / relative, error)) {
    return *larger / relative;
  }
  return std::nullopt;
}

/// The folder `relative` of the larger set when it is there (tests over a whole folder cover more with it),
/// else data/'s.
inline std::filesystem::path WidestDir(const std::string& relative) {
  std::error_code error;
  if (const auto larger = Larger(); larger && std::filesystem::is_directory(*larger / relative, error)) {
    return *larger / relative;
  }
  return Sample() / relative;
}

/// Why a test skips: what it needs and where that would be.
inline std::string NeedsLargerSet(const std::string& what) {
  return "needs " + what + " from the larger data set (" + std::string(SHARED_DATA_DIR) +
         ", e.g. ../shared/data), which is absent; data/ does not carry it";
}

}  // namespace test_data

/// Declares `const std::filesystem::path var` as the data file `relative` (see test_data::Find), or skips
/// the test naming the missing file. Only in a test body (GTEST_SKIP returns from the enclosing function).
#define TEST_DATA_FILE_OR_SKIP(var, relative)                                           \
  const auto var##_found = ::test_data::Find(relative);                                 \
  if (!var##_found) GTEST_SKIP() << ::test_data::NeedsLargerSet(std::string(relative)); \
  const std::filesystem::path var = *var##_found

/// Skips the test unless the larger data set is there; `what` says what the test needs from it.
#define REQUIRE_LARGER_DATA_OR_SKIP(what) \
  if (!::test_data::Larger()) GTEST_SKIP() << ::test_data::NeedsLargerSet(what)
