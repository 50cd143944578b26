#include "mapper_params_file.h"

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace slamtool {
namespace {

using nlohmann::json;
using slamcore::InvalidArgument;
using slamcore::Status;

/// Reads the keys of one JSON object into fields, refusing unknown keys and wrong types.
class ObjectReader {
 public:
  ObjectReader(const json& object, std::string path) : object_(object), path_(std::move(path)) {}

  template <typename T>
  Status Read(const char* key, T* field) {
    seen_.push_back(key);
    const auto it = object_.find(key);
    if (it == object_.end()) return Status::Ok();
    const bool type_ok = std::is_same_v<T, bool> ? it->is_boolean()
                         : std::is_integral_v<T> ? it->is_number_integer()
                                                 : it->is_number();
    if (!type_ok) return InvalidArgument(path_ + key + ": expected " + TypeName<T>() + ", found " + it->dump());
    *field = it->get<T>();
    return Status::Ok();
  }

  Status ReadCriteria(const char* key, slamcore::AcceptanceCriteria* criteria) {
    seen_.push_back(key);
    const auto it = object_.find(key);
    if (it == object_.end()) return Status::Ok();
    if (!it->is_object()) return InvalidArgument(path_ + key + ": expected an object");
    ObjectReader nested(*it, path_ + key + ".");
    SLAMCORE_RETURN_IF_ERROR(nested.Read("min_observations", &criteria->min_observations));
    SLAMCORE_RETURN_IF_ERROR(nested.Read("min_views", &criteria->min_views));
    return nested.RefuseUnknownKeys();
  }

  Status RefuseUnknownKeys() const {
    for (const auto& [key, unused] : object_.items()) {
      if (std::find(seen_.begin(), seen_.end(), key) == seen_.end()) {
        return InvalidArgument(path_ + key + ": unknown parameter");
      }
    }
    return Status::Ok();
  }

 private:
  template <typename T>
  static const char* TypeName() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    if constexpr (std::is_integral_v<T>) return "an integer";
    return "a number";
  }

  const json& object_;
  std::string path_;
  std::vector<std::string> seen_;
};

}  // namespace

slamcore::Result<slamcore::MapperParams> ParseMapperParams(const std::string& json_text, const std::string& source) {
  json document;
  try {
    document = json::parse(json_text);
  } catch (const json::parse_error& error) {
    return InvalidArgument(source + ": not valid JSON: " + error.what());
  }
  if (!document.is_object()) return InvalidArgument(source + ": expected a JSON object of parameters");
  slamcore::MapperParams params;
  ObjectReader reader(document, source + ": ");
  SLAMCORE_RETURN_IF_ERROR(reader.Read("gate_chi2", &params.gate_chi2));
  SLAMCORE_RETURN_IF_ERROR(reader.ReadCriteria("recovery", &params.recovery));
  SLAMCORE_RETURN_IF_ERROR(reader.ReadCriteria("merge_conditional", &params.merge_conditional));
  SLAMCORE_RETURN_IF_ERROR(reader.ReadCriteria("merge_full", &params.merge_full));
  SLAMCORE_RETURN_IF_ERROR(reader.Read("conditional_merge", &params.conditional_merge));
  SLAMCORE_RETURN_IF_ERROR(reader.Read("hypothesis_expiry_seconds", &params.hypothesis_expiry_seconds));
  SLAMCORE_RETURN_IF_ERROR(reader.Read("hypothesis_expiry_distance", &params.hypothesis_expiry_distance));
  SLAMCORE_RETURN_IF_ERROR(reader.Read("ambiguity_window_distance", &params.ambiguity_window_distance));
  SLAMCORE_RETURN_IF_ERROR(reader.Read("ambiguity_min_rejections", &params.ambiguity_min_rejections));
  SLAMCORE_RETURN_IF_ERROR(reader.Read("discount_ambiguous_in_merge", &params.discount_ambiguous_in_merge));
  SLAMCORE_RETURN_IF_ERROR(reader.Read("optimize_after_accept", &params.optimize_after_accept));
  SLAMCORE_RETURN_IF_ERROR(reader.RefuseUnknownKeys());
  if (const Status status = params.Validate(); !status.ok()) {
    return InvalidArgument(source + ": " + status.message());
  }
  return params;
}

slamcore::Result<slamcore::MapperParams> ReadMapperParams(const std::string& path) {
  std::ifstream input(path);
  if (!input) return slamcore::NotFound(path + ": cannot open file");
  std::ostringstream text;
  text << input.rdbuf();
  return ParseMapperParams(text.str(), path);
}

}  // namespace slamtool
