#include "slamcore/mapper_params.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>
#include <limits>

#include "slamcore/mapper.h"

namespace slamcore {
namespace {

using ::testing::HasSubstr;

TEST(MapperParamsTest, DefaultsAreValid) { EXPECT_TRUE(MapperParams{}.Validate().ok()); }

struct BadField {
  std::string field;
  std::function<void(MapperParams&)> spoil;
  std::string value;  // as it must appear in the message
};

TEST(MapperParamsTest, EveryBadFieldIsNamedWithItsValue) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<BadField> cases = {
      {"gate_chi2", [](MapperParams& p) { p.gate_chi2 = 0.0; }, "0"},
      {"gate_chi2", [&](MapperParams& p) { p.gate_chi2 = nan; }, "nan"},
      {"recovery.min_observations", [](MapperParams& p) { p.recovery.min_observations = 0; }, "0"},
      {"recovery.min_views", [](MapperParams& p) { p.recovery.min_views = -1; }, "-1"},
      {"recovery.min_views", [](MapperParams& p) { p.recovery.min_views = 4; }, "4"},  // > min_observations
      {"merge_conditional.min_observations", [](MapperParams& p) { p.merge_conditional.min_observations = 0; }, "0"},
      {"merge_conditional.min_views", [](MapperParams& p) { p.merge_conditional.min_views = 3; }, "3"},
      {"merge_full.min_views", [](MapperParams& p) { p.merge_full.min_views = 0; }, "0"},
      {"merge_full.min_observations", [](MapperParams& p) { p.merge_full.min_observations = 1; }, "1"},
      {"merge_full.min_views",
       [](MapperParams& p) {
         p.merge_conditional = {.min_observations = 2, .min_views = 2};
         p.merge_full = {.min_observations = 4, .min_views = 1};
       },
       "1"},
      {"hypothesis_expiry_seconds", [](MapperParams& p) { p.hypothesis_expiry_seconds = -1.0; }, "-1"},
      {"hypothesis_expiry_distance", [&](MapperParams& p) { p.hypothesis_expiry_distance = inf; }, "inf"},
      {"ambiguity_window_distance", [](MapperParams& p) { p.ambiguity_window_distance = 0.0; }, "0"},
      {"ambiguity_min_rejections", [](MapperParams& p) { p.ambiguity_min_rejections = 0; }, "0"},
      {"optimizer", [](MapperParams& p) { p.optimizer.max_iterations = 0; }, "max_iterations"},
      {"optimizer", [](MapperParams& p) { p.optimizer.num_threads = 0; }, "num_threads"},
  };
  for (const BadField& bad : cases) {
    MapperParams params;
    bad.spoil(params);
    const Status status = params.Validate();
    ASSERT_FALSE(status.ok()) << bad.field;
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(status.message(), HasSubstr(bad.field)) << status.message();
    EXPECT_THAT(status.message(), HasSubstr(bad.value)) << status.message();
    // And a Mapper refuses them.
    EXPECT_FALSE(Mapper::Create(params).ok()) << bad.field;
  }
}

TEST(MapperParamsTest, EqualConditionalAndFullCriteriaAreAllowed) {
  MapperParams params;
  params.merge_conditional = params.merge_full;
  EXPECT_TRUE(params.Validate().ok());
}

}  // namespace
}  // namespace slamcore
