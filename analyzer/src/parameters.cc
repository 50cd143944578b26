#include "analyzer/parameters.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>

namespace analyzer {
namespace {

/// The field of `message` a JSON key names, by its proto or its JSON name (protobuf's JSON reads both).
const google::protobuf::FieldDescriptor* FieldNamed(const google::protobuf::Descriptor& message,
                                                    const std::string& key) {
  const google::protobuf::FieldDescriptor* field = message.FindFieldByName(key);
  for (int k = 0; field == nullptr && k < message.field_count(); ++k) {
    if (message.field(k)->json_name() == key) field = message.field(k);
  }
  return field;
}

/// The first key of the JSON object `object` that `message` has no field for, as a dotted path, with the
/// names that level does know: protobuf's own refusal ("Cannot find field.") names neither.
std::optional<std::string> UnknownField(const nlohmann::json& object,
                                        const google::protobuf::Descriptor& message,
                                        const std::string& prefix) {
  for (const auto& [key, value] : object.items()) {
    const google::protobuf::FieldDescriptor* field = FieldNamed(message, key);
    if (field == nullptr) {
      std::string known;
      for (int k = 0; k < message.field_count(); ++k)
        known += (k == 0 ? "" : ", ") + message.field(k)->json_name();
      return "unknown parameter '" + prefix + key + "' (known" +
             (prefix.empty() ? "" : " in " + prefix.substr(0, prefix.size() - 1)) + ": " + known + ")";
    }
    if (field->type() == google::protobuf::FieldDescriptor::TYPE_MESSAGE && !field->is_repeated() &&
        value.is_object()) {
      if (auto unknown = UnknownField(value, *field->message_type(), prefix + key + ".")) return unknown;
    }
  }
  return std::nullopt;
}

}  // namespace

fleet::v1::MapperParameters ToProto(const slamcore::MapperParams& params) {
  fleet::v1::MapperParameters proto;
  proto.set_gate_chi2(params.gate_chi2);
  proto.set_direct_max_position_sigma(params.direct_max_position_sigma);
  auto criteria = [](const slamcore::AcceptanceCriteria& from, fleet::v1::AcceptanceCriteria* to) {
    to->set_min_observations(from.min_observations);
    to->set_min_views(from.min_views);
  };
  criteria(params.recovery, proto.mutable_recovery());
  criteria(params.merge_conditional, proto.mutable_merge_conditional());
  criteria(params.merge_full, proto.mutable_merge_full());
  proto.set_conditional_merge(params.conditional_merge);
  proto.set_hypothesis_expiry_seconds(params.hypothesis_expiry_seconds);
  proto.set_hypothesis_expiry_distance(params.hypothesis_expiry_distance);
  proto.set_ambiguity_window_distance(params.ambiguity_window_distance);
  proto.set_ambiguity_min_rejections(params.ambiguity_min_rejections);
  proto.set_discount_ambiguous_in_merge(params.discount_ambiguous_in_merge);
  proto.set_optimize_after_accept(params.optimize_after_accept);
  proto.set_local_window_nodes(params.local_window_nodes);
  proto.set_full_optimization_every(params.full_optimization_every);
  proto.set_correct_slip_from_views(params.correct_slip_from_views);
  const slamcore::ConsistencyParams& c = params.consistency;
  fleet::v1::ConsistencyParameters* consistency = proto.mutable_consistency();
  consistency->set_enabled(c.enabled);
  consistency->set_pass_gap_seconds(c.pass_gap_seconds);
  consistency->set_pass_gap_distance(c.pass_gap_distance);
  consistency->set_map_gate_chi2(c.map_gate_chi2);
  consistency->set_min_redundancy_for_scaling(c.min_redundancy_for_scaling);
  consistency->set_min_variance_factor(c.min_variance_factor);
  consistency->set_aliasing_offset(c.aliasing_offset);
  consistency->set_min_passes_uninformative(c.min_passes_uninformative);
  consistency->set_min_passes_against_map(c.min_passes_against_map);
  consistency->set_verify_after_optimization(c.verify_after_optimization);
  consistency->set_retraction_confidence(c.retraction_confidence);
  consistency->set_max_open_hypotheses(c.max_open_hypotheses);
  consistency->set_max_continuation_edges(c.max_continuation_edges);
  consistency->set_max_judged_per_check(c.max_judged_per_check);
  consistency->set_max_retractions_per_check(c.max_retractions_per_check);
  consistency->set_max_edges_judged(c.max_edges_judged);
  consistency->set_max_contest_trials(c.max_contest_trials);
  consistency->set_max_marginal_update_nodes(c.max_marginal_update_nodes);
  consistency->set_consistent_set_check(c.consistent_set_check);
  consistency->set_status_quo_first(c.status_quo_first);
  consistency->set_consistent_set_confidence(c.consistent_set_confidence);
  consistency->set_consistent_set_growth(c.consistent_set_growth);
  consistency->set_max_kept_refused(c.max_kept_refused);
  consistency->set_gnc_max_iterations(c.gnc_max_iterations);
  return proto;
}

slamcore::Result<slamcore::MapperParams> FromProto(const fleet::v1::MapperParameters& proto) {
  slamcore::MapperParams params;
  if (proto.has_gate_chi2()) params.gate_chi2 = proto.gate_chi2();
  if (proto.has_direct_max_position_sigma())
    params.direct_max_position_sigma = proto.direct_max_position_sigma();
  auto criteria = [](const fleet::v1::AcceptanceCriteria& from, slamcore::AcceptanceCriteria* to) {
    if (from.has_min_observations()) to->min_observations = from.min_observations();
    if (from.has_min_views()) to->min_views = from.min_views();
  };
  criteria(proto.recovery(), &params.recovery);
  criteria(proto.merge_conditional(), &params.merge_conditional);
  criteria(proto.merge_full(), &params.merge_full);
  if (proto.has_conditional_merge()) params.conditional_merge = proto.conditional_merge();
  if (proto.has_correct_slip_from_views()) params.correct_slip_from_views = proto.correct_slip_from_views();
  if (proto.has_hypothesis_expiry_seconds())
    params.hypothesis_expiry_seconds = proto.hypothesis_expiry_seconds();
  if (proto.has_hypothesis_expiry_distance())
    params.hypothesis_expiry_distance = proto.hypothesis_expiry_distance();
  if (proto.has_ambiguity_window_distance())
    params.ambiguity_window_distance = proto.ambiguity_window_distance();
  if (proto.has_ambiguity_min_rejections())
    params.ambiguity_min_rejections = proto.ambiguity_min_rejections();
  if (proto.has_discount_ambiguous_in_merge()) {
    params.discount_ambiguous_in_merge = proto.discount_ambiguous_in_merge();
  }
  if (proto.has_optimize_after_accept()) params.optimize_after_accept = proto.optimize_after_accept();
  if (proto.has_local_window_nodes()) params.local_window_nodes = proto.local_window_nodes();
  if (proto.has_full_optimization_every()) params.full_optimization_every = proto.full_optimization_every();
  const fleet::v1::ConsistencyParameters& from = proto.consistency();
  slamcore::ConsistencyParams& c = params.consistency;
  if (from.has_enabled()) c.enabled = from.enabled();
  if (from.has_pass_gap_seconds()) c.pass_gap_seconds = from.pass_gap_seconds();
  if (from.has_pass_gap_distance()) c.pass_gap_distance = from.pass_gap_distance();
  if (from.has_map_gate_chi2()) c.map_gate_chi2 = from.map_gate_chi2();
  if (from.has_min_redundancy_for_scaling()) c.min_redundancy_for_scaling = from.min_redundancy_for_scaling();
  if (from.has_min_variance_factor()) c.min_variance_factor = from.min_variance_factor();
  if (from.has_aliasing_offset()) c.aliasing_offset = from.aliasing_offset();
  if (from.has_min_passes_uninformative()) c.min_passes_uninformative = from.min_passes_uninformative();
  if (from.has_min_passes_against_map()) c.min_passes_against_map = from.min_passes_against_map();
  if (from.has_verify_after_optimization()) c.verify_after_optimization = from.verify_after_optimization();
  if (from.has_retraction_confidence()) c.retraction_confidence = from.retraction_confidence();
  if (from.has_max_open_hypotheses()) c.max_open_hypotheses = from.max_open_hypotheses();
  if (from.has_max_continuation_edges()) c.max_continuation_edges = from.max_continuation_edges();
  if (from.has_max_judged_per_check()) c.max_judged_per_check = from.max_judged_per_check();
  if (from.has_max_retractions_per_check()) c.max_retractions_per_check = from.max_retractions_per_check();
  if (from.has_max_edges_judged()) c.max_edges_judged = from.max_edges_judged();
  if (from.has_max_contest_trials()) c.max_contest_trials = from.max_contest_trials();
  if (from.has_max_marginal_update_nodes()) c.max_marginal_update_nodes = from.max_marginal_update_nodes();
  if (from.has_consistent_set_check()) c.consistent_set_check = from.consistent_set_check();
  if (from.has_status_quo_first()) c.status_quo_first = from.status_quo_first();
  if (from.has_consistent_set_confidence()) c.consistent_set_confidence = from.consistent_set_confidence();
  if (from.has_consistent_set_growth()) c.consistent_set_growth = from.consistent_set_growth();
  if (from.has_max_kept_refused()) c.max_kept_refused = from.max_kept_refused();
  if (from.has_gnc_max_iterations()) c.gnc_max_iterations = from.gnc_max_iterations();
  RETURN_IF_ERROR(params.Validate());
  return params;
}

slamcore::Result<fleet::v1::ParameterSet> ParseParameterSetJson(const std::string& json,
                                                                const std::string& source) {
  if (json.size() > kMaxParameterSetJsonBytes) {
    return slamcore::InvalidArgument(source + ": " + std::to_string(json.size()) + " bytes, more than the " +
                                     std::to_string(kMaxParameterSetJsonBytes) + " a parameter set may have");
  }
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  // A whole set ({"name", "mapper": {…}}) or the mapper's parameters alone. Each is parsed, and an unknown
  // key named, as the shape the file has (trying one shape and then the other reported the second's
  // complaint about the first's keys: "mapper: Cannot find field.").
  const nlohmann::json parsed = nlohmann::json::parse(json, nullptr, /*allow_exceptions=*/false);
  const google::protobuf::Descriptor& whole = *fleet::v1::ParameterSet::descriptor();
  // A key of ParameterSet's own ("name", "mapper", …) makes the file a whole set.
  const bool whole_set = parsed.is_object() && std::ranges::any_of(parsed.items(), [&](const auto& item) {
                           return FieldNamed(whole, item.key()) != nullptr;
                         });
  if (parsed.is_object()) {
    const google::protobuf::Descriptor& shape =
        whole_set ? whole : *fleet::v1::MapperParameters::descriptor();
    if (const auto unknown = UnknownField(parsed, shape, ""))
      return slamcore::InvalidArgument(source + ": " + *unknown);
  }
  fleet::v1::ParameterSet set;
  if (whole_set) {
    if (const auto status = google::protobuf::util::JsonStringToMessage(json, &set, options); !status.ok())
      return slamcore::InvalidArgument(source + ": " + std::string(status.message()));
    if (!set.has_mapper()) return slamcore::InvalidArgument(source + ": a parameter set needs \"mapper\"");
  } else if (const auto status =
                 google::protobuf::util::JsonStringToMessage(json, set.mutable_mapper(), options);
             !status.ok()) {
    return slamcore::InvalidArgument(source + ": " + std::string(status.message()));
  }
  if (const auto params = FromProto(set.mapper()); !params.ok())
    return slamcore::InvalidArgument(source + ": " + params.status().message());
  return set;
}

slamcore::Result<fleet::v1::ParameterSet> ReadParameterSetFile(const std::string& path) {
  std::ifstream input(path, std::ios::binary);
  if (!input) return slamcore::NotFound(path + ": cannot open file");
  // Read one byte past the bound at most, so that an oversized file is refused without being loaded.
  std::string text(kMaxParameterSetJsonBytes + 1, '\0');
  input.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(input.gcount()));
  if (text.size() > kMaxParameterSetJsonBytes) {
    return slamcore::InvalidArgument(path + ": more than the " + std::to_string(kMaxParameterSetJsonBytes) +
                                     " bytes a parameter set may have");
  }
  return ParseParameterSetJson(text, path);
}

slamcore::Result<slamcore::MapperParams> ReadMapperParamsFile(const std::string& path) {
  ASSIGN_OR_RETURN(const fleet::v1::ParameterSet set, ReadParameterSetFile(path));
  return FromProto(set.mapper());
}

}  // namespace analyzer
