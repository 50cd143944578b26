#include "analyzer/parameters.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "status_matchers.h"

namespace analyzer {
namespace {

TEST(ParametersTest, DefaultsRoundTrip) {
  const slamcore::MapperParams defaults;
  const auto back = FromProto(ToProto(defaults));
  ASSERT_THAT(back, IsOk());
  EXPECT_EQ(back->gate_chi2, defaults.gate_chi2);
  EXPECT_EQ(back->merge_full.min_views, defaults.merge_full.min_views);
  EXPECT_EQ(back->conditional_merge, defaults.conditional_merge);
  EXPECT_EQ(back->local_window_nodes, defaults.local_window_nodes);
}

TEST(ParametersTest, JsonNamesOnlyWhatItChanges) {
  const auto set = ParseParameterSetJson(
      R"({"name": "strict", "mapper": {"gateChi2": 7.8, "mergeFull": {"minViews": 3}, "conditionalMerge": false}})",
      "strict.json");
  ASSERT_THAT(set, IsOk());
  EXPECT_EQ(set->name(), "strict");
  const auto params = FromProto(set->mapper());
  ASSERT_THAT(params, IsOk());
  EXPECT_EQ(params->gate_chi2, 7.8);
  EXPECT_EQ(params->merge_full.min_views, 3);
  EXPECT_EQ(params->merge_full.min_observations, slamcore::MapperParams().merge_full.min_observations);
  EXPECT_FALSE(params->conditional_merge);
  EXPECT_EQ(params->recovery.min_views, slamcore::MapperParams().recovery.min_views);
}

TEST(ParametersTest, ConsistencyChecksAreParametersToo) {
  // A what-if parameter set: the paper's filter alone, or other caps.
  const auto off = ParseParameterSetJson(
      R"({"consistency": {"enabled": false, "minPassesAgainstMap": 2, "maxMarginalUpdateNodes": 0,
                           "statusQuoFirst": false, "maxContestTrials": 0}})",
      "off.json");
  ASSERT_THAT(off, IsOk());
  const auto params = FromProto(off->mapper());
  ASSERT_THAT(params, IsOk());
  EXPECT_FALSE(params->consistency.enabled);
  EXPECT_EQ(params->consistency.min_passes_against_map, 2);
  EXPECT_EQ(params->consistency.max_open_hypotheses, slamcore::ConsistencyParams().max_open_hypotheses);
  const auto round_trip = FromProto(ToProto(*params));
  ASSERT_THAT(round_trip, IsOk());
  EXPECT_EQ(round_trip->consistency.min_passes_against_map, 2);
  EXPECT_EQ(round_trip->consistency.max_marginal_update_nodes, 0);  // factorise whenever G changed
  EXPECT_FALSE(round_trip->consistency.status_quo_first);           // every check in full
  EXPECT_TRUE(slamcore::ConsistencyParams().status_quo_first);
  EXPECT_EQ(round_trip->consistency.max_contest_trials, 0);  // no contest: the what-if baseline
  EXPECT_GT(slamcore::ConsistencyParams().max_contest_trials, 0);
  EXPECT_FALSE(round_trip->consistency.enabled);
  // Unbounded caps are refused, naming the field.
  const auto unbounded =
      ParseParameterSetJson(R"({"consistency": {"maxOpenHypotheses": 2147483647}})", "cap.json");
  ASSERT_FALSE(unbounded.ok());
  EXPECT_NE(unbounded.status().message().find("consistency.max_open_hypotheses"), std::string::npos)
      << unbounded.status().message();
  // The map test's update solves densely over the nodes it allows: its cap is bounded both ways too.
  for (const char* json : {R"({"consistency": {"maxMarginalUpdateNodes": 2147483647}})",
                           R"({"consistency": {"maxMarginalUpdateNodes": -1}})"}) {
    const auto refused = ParseParameterSetJson(json, "update.json");
    ASSERT_FALSE(refused.ok()) << json;
    EXPECT_NE(refused.status().message().find("consistency.max_marginal_update_nodes"), std::string::npos)
        << refused.status().message();
  }
  // Each contest trial is an optimisation of the component: bounded too.
  const auto endless =
      ParseParameterSetJson(R"({"consistency": {"maxContestTrials": 1000000}})", "contest.json");
  ASSERT_FALSE(endless.ok());
  EXPECT_NE(endless.status().message().find("consistency.max_contest_trials"), std::string::npos)
      << endless.status().message();
  // A switch takes a boolean (protobuf's JSON also reads "yes" / "no" as one); anything else is refused,
  // naming the file and the field.
  const auto not_a_switch =
      ParseParameterSetJson(R"({"consistency": {"statusQuoFirst": "banana"}})", "switch.json");
  ASSERT_FALSE(not_a_switch.ok());
  EXPECT_NE(not_a_switch.status().message().find("switch.json"), std::string::npos)
      << not_a_switch.status().message();
  EXPECT_NE(not_a_switch.status().message().find("consistency.status_quo_first"), std::string::npos)
      << not_a_switch.status().message();
}

// A misspelt or unknown key is named with its path and the keys that level knows, in either shape of file;
// a wrong value inside a whole set is named by its path too (trying a set, then bare parameters, reported
// "mapper: Cannot find field." for all three).
TEST(ParametersTest, AnUnknownKeyOrAWrongValueIsNamedWhereItIs) {
  const auto misspelt = ParseParameterSetJson(
      R"({"name": "x", "mapper": {"consistency": {"maxContestTrial": 1}}})", "set.json");
  ASSERT_FALSE(misspelt.ok());
  EXPECT_THAT(std::string(misspelt.status().message()),
              ::testing::StartsWith("set.json: unknown parameter 'mapper.consistency.maxContestTrial' (known "
                                    "in mapper.consistency: enabled, "));
  EXPECT_NE(misspelt.status().message().find("maxContestTrials"), std::string::npos);
  const auto bare = ParseParameterSetJson(R"({"gateChi2": 9, "gateChi": 9})", "bare.json");
  ASSERT_FALSE(bare.ok());
  EXPECT_THAT(std::string(bare.status().message()),
              ::testing::StartsWith("bare.json: unknown parameter 'gateChi' (known: gateChi2, "));
  const auto wrong_value =
      ParseParameterSetJson(R"({"mapper": {"recovery": {"minObservations": "three"}}})", "value.json");
  ASSERT_FALSE(wrong_value.ok());
  EXPECT_NE(wrong_value.status().message().find("mapper.recovery.min_observations"), std::string::npos)
      << wrong_value.status().message();
  const auto no_mapper = ParseParameterSetJson(R"({"name": "empty"})", "empty.json");
  ASSERT_FALSE(no_mapper.ok());
  EXPECT_EQ(no_mapper.status().message(), "empty.json: a parameter set needs \"mapper\"");
}

// Hostile files: an oversized one is refused by its size before either parse, read no further than the
// bound; nesting far deeper than any parameter set (inside the bound) is refused, not a crash.
TEST(ParametersTest, OversizedOrDeeplyNestedJsonIsRefused) {
  const std::string padded =
      R"({"name": ")" + std::string(kMaxParameterSetJsonBytes, 'x') + R"(", "mapper": {}})";
  const auto oversized = ParseParameterSetJson(padded, "big.json");
  ASSERT_FALSE(oversized.ok());
  EXPECT_NE(oversized.status().message().find("a parameter set may have"), std::string::npos)
      << oversized.status().message();
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "parameters_test_big.json";
  { std::ofstream(file) << padded; }
  const auto from_file = ReadParameterSetFile(file.string());
  std::filesystem::remove(file);
  ASSERT_FALSE(from_file.ok());
  EXPECT_NE(from_file.status().message().find("a parameter set may have"), std::string::npos);
  const int depth = 50000;
  const std::string nested =
      R"({"mapper": {"recovery": )" + std::string(depth, '[') + std::string(depth, ']') + "}}";
  ASSERT_LE(nested.size(), kMaxParameterSetJsonBytes);
  const auto deep = ParseParameterSetJson(nested, "deep.json");
  ASSERT_FALSE(deep.ok());
  EXPECT_NE(deep.status().message().find("deep.json"), std::string::npos) << deep.status().message();
}

TEST(ParametersTest, BareMapperObjectIsAccepted) {
  const auto set = ParseParameterSetJson(R"({"gate_chi2": 9.0})", "bare.json");
  ASSERT_THAT(set, IsOk());
  EXPECT_EQ(set->mapper().gate_chi2(), 9.0);
}

TEST(ParametersTest, UnknownKeysAndBadValuesAreRefusedNamingThem) {
  auto set = ParseParameterSetJson(R"({"gate_chi": 9.0})", "typo.json");
  ASSERT_FALSE(set.ok());
  EXPECT_NE(set.status().message().find("typo.json"), std::string::npos);
  EXPECT_NE(set.status().message().find("gate_chi"), std::string::npos) << set.status().message();

  set = ParseParameterSetJson(R"({"mapper": {"gateChi2": -1}})", "negative.json");
  ASSERT_FALSE(set.ok());
  EXPECT_NE(set.status().message().find("gate_chi2"), std::string::npos) << set.status().message();

  set = ParseParameterSetJson(R"({"mergeConditional": {"minViews": 5}})", "views.json");
  ASSERT_FALSE(set.ok());
  EXPECT_NE(set.status().message().find("merge_conditional.min_views"), std::string::npos)
      << set.status().message();

  EXPECT_EQ(ReadParameterSetFile("/nonexistent.json").status().code(), slamcore::StatusCode::kNotFound);
}

}  // namespace
}  // namespace analyzer
