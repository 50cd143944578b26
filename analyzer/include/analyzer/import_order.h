// The order in which `fleetctl import` brings a series of maps into a robot's history (docs/formats/
// map-versions.md "Imported maps"): a robot's history is a sequence in time, but files come in the order a
// shell's glob or a user lists them. `--order time` takes each file's time from the export's own timestamp
// where every file has one, else from a date-time in every file name, else from the numbers in every file
// name; when neither covers all the files they stay as given (and the output says why). `--order given`
// keeps them as listed.
//
// Thread safety: pure functions.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace analyzer {

/// 2100-01-01T00:00:00Z in milliseconds: no map of a robot is later.
inline constexpr std::int64_t kLatestTimeMs = 4102444800000;

/// "YYYY-MM-DD[(T| |_)HH[:-]MM[[:-]SS[.fff]]][Z|±HH:MM]" (the whole text) as milliseconds since the epoch,
/// UTC unless an offset is given; years 1970–2099; nullopt when it is not such a date-time.
std::optional<std::int64_t> ParseIsoDateTime(std::string_view text);

/// The first date-time in a file name: ISO 8601 as above (also with '-' between the time's fields, as file
/// names must) or compact "YYYYMMDD[(T|_|-)HHMMSS]"; nullopt when the name holds none.
std::optional<std::int64_t> DateTimeInName(std::string_view name);

/// The numbers in a file name, left to right ("map_3_v12.yaml" → {3, 12}); each at most 18 digits.
std::vector<std::int64_t> NumbersInName(std::string_view name);

struct ImportFile {
  std::string name;                         // the file's name (no directory)
  std::optional<std::int64_t> own_time_ms;  // the export's own timestamp, when it has one
};

struct ImportOrder {
  std::vector<std::size_t> order;  // indices into the files, first imported first
  std::string basis;  // "given", "export timestamps", "dates in file names", "numbers in file names"
  std::string note;   // why "given" under --order time (which file had no time), else empty
};

/// `by_time` false: as given. Ties keep the given order.
ImportOrder OrderImports(const std::vector<ImportFile>& files, bool by_time);

}  // namespace analyzer
