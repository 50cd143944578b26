// fleetd's configuration: a config file's keys reach the config, and Validate names the key out of range.
#include "server/config.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "server/map_history.h"
#include "status_matchers.h"

namespace server {
namespace {

class ConfigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ =
        std::filesystem::temp_directory_path() / ("fleetd_config_test_" + std::to_string(getpid()) + ".json");
  }
  void TearDown() override { std::filesystem::remove(path_); }
  slamcore::Status Load(const std::string& json, FleetdConfig& config) {
    std::ofstream(path_) << json;
    return LoadConfigFile(path_.string(), config);
  }
  std::filesystem::path path_;
};

TEST_F(ConfigTest, TheRepairPolicyKeysReachTheMapPolicyAndOutOfRangeValuesAreNamed) {
  FleetdConfig config;
  ASSERT_THAT(
      Load(R"({"auto_repair": "repair_findings", "auto_repair_min_severity": 0.6, "auto_approve": true,
               "auto_repair_protrusions": "any"})",
           config),
      IsOk());
  EXPECT_THAT(config.Validate(), IsOk());
  const MapPolicy policy = MapPolicyOf(config);
  EXPECT_EQ(policy.auto_repair, "repair_findings");
  EXPECT_DOUBLE_EQ(policy.min_severity, 0.6);
  EXPECT_EQ(policy.protrusions, "any");
  EXPECT_TRUE(policy.auto_approve);
  EXPECT_EQ(MapPolicyOf(FleetdConfig{}).protrusions, "views") << "the default cuts only what the views show";

  const auto refused = [&config](const std::string& expected) {
    const slamcore::Status status = config.Validate();
    EXPECT_EQ(status.code(), slamcore::StatusCode::kInvalidArgument) << expected;
    EXPECT_NE(status.message().find(expected), std::string::npos) << status.message();
  };
  config.auto_repair_min_severity = 1.5;
  refused("auto_repair_min_severity: expected 0 .. 1");
  config.auto_repair_min_severity = 0.6;
  config.auto_repair_protrusions = "model";
  refused("auto_repair_protrusions: expected any or views, got \"model\"");
  config.auto_repair_protrusions = "any";
  config.auto_repair = "cut_everything";
  refused("auto_repair: expected none, cut_protrusions or repair_findings, got \"cut_everything\"");
}

TEST_F(ConfigTest, AFileWithAnUnknownKeyOrTheWrongTypeIsRefusedNamingIt) {
  FleetdConfig config;
  const slamcore::Status misspelt = Load(R"({"auto_repiar": "none"})", config);
  EXPECT_EQ(misspelt.code(), slamcore::StatusCode::kInvalidArgument);
  EXPECT_NE(misspelt.message().find("unknown key \"auto_repiar\""), std::string::npos) << misspelt.message();
  const slamcore::Status wrong_type = Load(R"({"workers": "two"})", config);
  EXPECT_EQ(wrong_type.code(), slamcore::StatusCode::kInvalidArgument);
  EXPECT_NE(wrong_type.message().find("key \"workers\""), std::string::npos) << wrong_type.message();
  const slamcore::Status not_an_object = Load("[1, 2]", config);
  EXPECT_EQ(not_an_object.code(), slamcore::StatusCode::kInvalidArgument);
  EXPECT_NE(not_an_object.message().find("expected a JSON object"), std::string::npos);
  EXPECT_EQ(LoadConfigFile((path_.string() + ".absent"), config).code(), slamcore::StatusCode::kNotFound);
}

}  // namespace
}  // namespace server
