#include <charconv>
#include <string>

#include "sql_database.h"

namespace storage::internal {
namespace {

template <typename... Fs>
struct Overloaded : Fs... {
  using Fs::operator()...;
};
template <typename... Fs>
Overloaded(Fs...) -> Overloaded<Fs...>;

}  // namespace

Status SqlTransaction::Exec(const std::string& sql, const std::vector<SqlValue>& params) {
  return Query(sql, params).status();
}

std::int64_t SqlRow::Int(std::size_t i) const {
  return std::visit(
      Overloaded{[](const SqlNull&) -> std::int64_t { return 0; }, [](std::int64_t v) { return v; },
                 [](double v) { return static_cast<std::int64_t>(v); },
                 [](const std::string& v) {
                   std::int64_t out = 0;
                   std::from_chars(v.data(), v.data() + v.size(), out);
                   return out;
                 },
                 [](const SqlBlob&) -> std::int64_t { return 0; }},
      values_.at(i));
}

double SqlRow::Real(std::size_t i) const {
  return std::visit(
      Overloaded{[](const SqlNull&) { return 0.0; }, [](std::int64_t v) { return static_cast<double>(v); },
                 [](double v) { return v; },
                 [](const std::string& v) {
                   double out = 0.0;
                   std::from_chars(v.data(), v.data() + v.size(), out);
                   return out;
                 },
                 [](const SqlBlob&) { return 0.0; }},
      values_.at(i));
}

std::string SqlRow::Text(std::size_t i) const {
  return std::visit(
      Overloaded{[](const SqlNull&) { return std::string(); },
                 [](std::int64_t v) { return std::to_string(v); }, [](double v) { return std::to_string(v); },
                 [](const std::string& v) { return v; }, [](const SqlBlob& v) { return v.bytes; }},
      values_.at(i));
}

}  // namespace storage::internal
