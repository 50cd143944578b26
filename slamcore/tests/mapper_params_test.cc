#include "slamcore/mapper_params.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>
#include <limits>

#include "slamcore/mapper.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

using ::testing::HasSubstr;

TEST(MapperParamsTest, DefaultsAreValid) { EXPECT_THAT(MapperParams{}.Validate(), IsOk()); }

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
      {"merge_conditional.min_observations",
       [](MapperParams& p) { p.merge_conditional.min_observations = 0; }, "0"},
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
      // Upper bounds (MapperParamsLimits): the two parameter sets of issue 16 that made one replay unbounded.
      {"hypothesis_expiry_seconds", [](MapperParams& p) { p.hypothesis_expiry_seconds = 1e300; },
       "at most 3600"},
      {"local_window_nodes", [](MapperParams& p) { p.local_window_nodes = 2147483647; }, "[1, 10000]"},
      {"full_optimization_every", [](MapperParams& p) { p.full_optimization_every = 1000001; },
       "[1, 1000000]"},
      {"gate_chi2", [](MapperParams& p) { p.gate_chi2 = 1e6; }, "at most 1000"},
      {"recovery.min_observations", [](MapperParams& p) { p.recovery.min_observations = 5000; }, "[1, 1000]"},
      {"consistency.max_open_hypotheses", [](MapperParams& p) { p.consistency.max_open_hypotheses = 100000; },
       "[1, 10000]"},
      {"optimizer.max_iterations", [](MapperParams& p) { p.optimizer.max_iterations = 100000; }, "[1, 1000]"},
  };
  for (const BadField& bad : cases) {
    MapperParams params;
    bad.spoil(params);
    const Status status = params.Validate();
    ASSERT_FALSE(status.ok()) << bad.field;
    EXPECT_THAT(status, StatusIs(StatusCode::kInvalidArgument));
    EXPECT_THAT(status.message(), HasSubstr(bad.field)) << status.message();
    EXPECT_THAT(status.message(), HasSubstr(bad.value)) << status.message();
    // And a Mapper refuses them.
    EXPECT_FALSE(Mapper::Create(params).ok()) << bad.field;
  }
}

TEST(MapperParamsTest, TheDocumentedMaximaThemselvesAreAllowed) {
  MapperParams params;
  params.hypothesis_expiry_seconds = MapperParamsLimits::kMaxSeconds;
  params.hypothesis_expiry_distance = MapperParamsLimits::kMaxMeters;
  params.local_window_nodes = MapperParamsLimits::kMaxWindowNodes;
  params.full_optimization_every = MapperParamsLimits::kMaxOptimizationEvery;
  params.gate_chi2 = MapperParamsLimits::kMaxChi2;
  params.optimizer.max_iterations = MapperParamsLimits::kMaxIterations;
  EXPECT_THAT(params.Validate(), IsOk());
}

TEST(MapperParamsTest, EqualConditionalAndFullCriteriaAreAllowed) {
  MapperParams params;
  params.merge_conditional = params.merge_full;
  EXPECT_THAT(params.Validate(), IsOk());
}

}  // namespace
}  // namespace slamcore
