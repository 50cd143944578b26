#include "analyzer/import_order.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <numeric>

namespace analyzer {
namespace {

/// Reads exactly `digits` decimal digits at `at`; advances `at`.
std::optional<int> Digits(std::string_view text, std::size_t& at, int digits) {
  if (at + digits > text.size()) return std::nullopt;
  int value = 0;
  for (int i = 0; i < digits; ++i) {
    const char c = text[at + i];
    if (!std::isdigit(static_cast<unsigned char>(c))) return std::nullopt;
    value = value * 10 + (c - '0');
  }
  at += digits;
  return value;
}

bool Accept(std::string_view text, std::size_t& at, std::string_view choices) {
  if (at < text.size() && choices.find(text[at]) != std::string_view::npos) {
    ++at;
    return true;
  }
  return false;
}

std::optional<std::int64_t> ToMillis(int year, int month, int day, int hour, int minute, int second,
                                     int millis, int offset_minutes) {
  using namespace std::chrono;
  if (year < 1970 || year > 2099 || hour > 23 || minute > 59 || second > 60) return std::nullopt;
  const year_month_day date{std::chrono::year(year), std::chrono::month(static_cast<unsigned>(month)),
                            std::chrono::day(static_cast<unsigned>(day))};
  if (!date.ok()) return std::nullopt;
  const auto days = sys_days(date).time_since_epoch().count();
  return ((static_cast<std::int64_t>(days) * 24 + hour) * 60 + minute - offset_minutes) * 60000 +
         static_cast<std::int64_t>(second) * 1000 + millis;
}

/// A date-time starting at `at`: extended ("2024-03-05T10:20:30") when `extended`, else compact
/// ("20240305T102030"); `time_separators` are what may stand between the time's fields. Sets `end`.
std::optional<std::int64_t> DateTimeAt(std::string_view text, std::size_t at, bool extended,
                                       std::string_view time_separators, std::size_t* end) {
  const auto year = Digits(text, at, 4);
  if (!year || (extended && !Accept(text, at, "-"))) return std::nullopt;
  const auto month = Digits(text, at, 2);
  if (!month || (extended && !Accept(text, at, "-"))) return std::nullopt;
  const auto day = Digits(text, at, 2);
  if (!day) return std::nullopt;
  int hour = 0, minute = 0, second = 0, millis = 0, offset = 0;
  std::size_t after_date = at;
  if (Accept(text, at, "T _-")) {
    std::size_t time_at = at;
    const auto h = Digits(text, time_at, 2);
    const bool separated = extended && Accept(text, time_at, time_separators);
    const auto m = h ? Digits(text, time_at, 2) : std::nullopt;
    if (h && m && (separated || !extended)) {
      hour = *h;
      minute = *m;
      at = time_at;
      std::size_t seconds_at = at;
      if ((!extended || Accept(text, seconds_at, time_separators))) {
        if (const auto s = Digits(text, seconds_at, 2)) {
          second = *s;
          at = seconds_at;
          std::size_t fraction_at = at;
          if (Accept(text, fraction_at, ".,")) {
            if (const auto f = Digits(text, fraction_at, 3)) {
              millis = *f;
              at = fraction_at;
            }
          }
        }
      }
      after_date = at;
      if (Accept(text, at, "Z")) {
        after_date = at;
      } else if (at < text.size() && (text[at] == '+' || text[at] == '-') && extended) {
        std::size_t zone_at = at + 1;
        const auto zh = Digits(text, zone_at, 2);
        Accept(text, zone_at, ":");
        const auto zm = zh ? Digits(text, zone_at, 2) : std::nullopt;
        if (zh && zm) {
          offset = (*zh * 60 + *zm) * (text[at] == '-' ? -1 : 1);
          after_date = zone_at;
        }
      }
    }
  }
  *end = after_date;
  return ToMillis(*year, *month, *day, hour, minute, second, millis, offset);
}

}  // namespace

std::optional<std::int64_t> ParseIsoDateTime(std::string_view text) {
  std::size_t end = 0;
  const auto time = DateTimeAt(text, 0, /*extended=*/true, ":", &end);
  if (!time || end != text.size()) return std::nullopt;
  return time;
}

std::optional<std::int64_t> DateTimeInName(std::string_view name) {
  for (std::size_t at = 0; at + 8 <= name.size(); ++at) {
    if (at > 0 && std::isdigit(static_cast<unsigned char>(name[at - 1]))) continue;  // inside a longer number
    std::size_t end = 0;
    if (auto time = DateTimeAt(name, at, /*extended=*/true, ":-.", &end)) return time;
    if (auto time = DateTimeAt(name, at, /*extended=*/false, "", &end)) {
      if (end >= name.size() || !std::isdigit(static_cast<unsigned char>(name[end]))) return time;
    }
  }
  return std::nullopt;
}

std::vector<std::int64_t> NumbersInName(std::string_view name) {
  std::vector<std::int64_t> numbers;
  for (std::size_t at = 0; at < name.size();) {
    if (!std::isdigit(static_cast<unsigned char>(name[at]))) {
      ++at;
      continue;
    }
    std::int64_t value = 0;
    int digits = 0;
    for (; at < name.size() && std::isdigit(static_cast<unsigned char>(name[at])); ++at) {
      if (digits++ < 18) value = value * 10 + (name[at] - '0');  // longer runs keep their first 18 digits
    }
    numbers.push_back(value);
  }
  return numbers;
}

ImportOrder OrderImports(const std::vector<ImportFile>& files, bool by_time) {
  ImportOrder result;
  result.order.resize(files.size());
  std::iota(result.order.begin(), result.order.end(), 0);
  result.basis = "given";
  if (!by_time || files.size() < 2) return result;
  // The first key every file has decides; a mix of keys would order apples against pears.
  std::vector<std::vector<std::int64_t>> keys(files.size());
  const auto all = [&](auto key_of) {
    for (std::size_t i = 0; i < files.size(); ++i) {
      keys[i] = key_of(files[i]);
      if (keys[i].empty()) return static_cast<long>(i);
    }
    return -1L;
  };
  const auto own = [](const ImportFile& file) {
    return file.own_time_ms ? std::vector<std::int64_t>{*file.own_time_ms} : std::vector<std::int64_t>{};
  };
  const auto dated = [](const ImportFile& file) {
    const auto time = DateTimeInName(file.name);
    return time ? std::vector<std::int64_t>{*time} : std::vector<std::int64_t>{};
  };
  const auto numbered = [](const ImportFile& file) { return NumbersInName(file.name); };
  long missing = all(own);
  result.basis = "export timestamps";
  if (missing >= 0) {
    missing = all(dated);
    result.basis = "dates in file names";
  }
  if (missing >= 0) {
    missing = all(numbered);
    result.basis = "numbers in file names";
  }
  if (missing >= 0) {
    std::iota(result.order.begin(), result.order.end(), 0);
    result.basis = "given";
    result.note = files[static_cast<std::size_t>(missing)].name +
                  " has no timestamp of its own and no date or number in its name";
    return result;
  }
  std::stable_sort(result.order.begin(), result.order.end(),
                   [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
  return result;
}

}  // namespace analyzer
