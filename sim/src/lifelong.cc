#include "sim/lifelong.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>

#include <nlohmann/json.hpp>
#include <unistd.h>

#include "fleet_client/local_fleetd.h"
#include "sim/follow_service.h"
#include "sim/service_client.h"

namespace sim {
namespace {

bool KnownRegime(const std::string& name) {
  return name == "none" || name == "filter" || name == "service" || name == "review";
}

RegimeResult Summarise(const std::string& name, FleetStatistics statistics, int runs) {
  RegimeResult result;
  result.name = name;
  result.corrupted_by_run.assign(static_cast<std::size_t>(runs), 0.0);
  const double robots = static_cast<double>(std::max<std::size_t>(1, statistics.health.size()));
  double first_corruption_sum = 0.0;
  for (const auto& robot : statistics.health) {
    std::optional<int> first;
    for (std::size_t k = 0; k < robot.size(); ++k) {
      result.repairs_taken += robot[k].repairs_taken;
      if (!robot[k].map.corrupted) continue;
      result.corrupted_by_run[k] += 1.0 / robots;
      ++result.runs_lost;
      if (!first) first = static_cast<int>(k) + 1;
    }
    if (first) {
      ++result.robots_ever_corrupted;
      first_corruption_sum += *first;
    }
  }
  result.corrupted_share = result.corrupted_by_run.empty() ? 0.0 : result.corrupted_by_run.back();
  result.mean_runs_to_corruption =
      result.robots_ever_corrupted > 0 ? first_corruption_sum / result.robots_ever_corrupted : 0.0;
  result.seconds = statistics.wall_seconds;
  result.statistics = std::move(statistics);
  return result;
}

/// Robot tokens minted on first use with the experiment's admin token.
class Tokens {
 public:
  Tokens(ServiceClient& client, std::string admin) : client_(client), admin_(std::move(admin)) {}
  std::string Of(const std::string& principal) {
    std::lock_guard lock(mutex_);
    auto& token = tokens_[principal];
    if (token.empty()) {
      auto minted = client_.MintToken(admin_, principal);
      if (minted.ok()) token = *minted;  // an empty token is refused by fleetd, naming the problem
    }
    return token;
  }

 private:
  ServiceClient& client_;
  std::string admin_;
  std::mutex mutex_;
  std::map<std::string, std::string> tokens_;
};

slamcore::Result<RegimeResult> RunRegime(const LifelongOptions& options, const std::string& name,
                                         const std::function<void(int, int)>& progress) {
  FleetOptions fleet;
  fleet.worlds = options.worlds;
  fleet.robots = options.robots;
  fleet.runs = options.runs;
  fleet.seed = options.seed;
  fleet.threads = options.threads;
  fleet.params = options.params;
  fleet.params.run_minutes = options.run_minutes;
  fleet.params.label_regions = false;  // the protrusion truth pairs are not needed here
  fleet.measure_map_health = true;
  fleet.corruption = options.corruption;
  if (name == "none") fleet.params.mapper = UnprotectedMapperParams();
  if (name == "none" || name == "filter") {
    ASSIGN_OR_RETURN(auto statistics, SimulateFleet(fleet, progress));
    return Summarise(name, std::move(statistics), options.runs);
  }

  // A fleetd of the regime's own: a fresh database and log in work_dir/<regime>, text logs.
  if (access(options.fleetd.c_str(), X_OK) != 0) {
    return slamcore::FailedPrecondition("fleetd: " + options.fleetd.string() +
                                        " is not an executable (build fleetd, or pass --fleetd)");
  }
  fleet_client::LocalFleetdOptions service;
  service.binary = options.fleetd;
  service.directory = options.work_dir / name;
  service.flags = {"--log-format",
                   "text",
                   "--auto-repair",
                   "repair_findings",
                   "--auto-repair-min-severity",
                   std::to_string(options.min_severity),
                   "--auto-repair-protrusions",
                   options.protrusions};
  if (name == "service") service.flags.push_back("--auto-approve");
  service.admin_token = fleet_client::RandomToken("admin:lifelong");
  fleet_client::LocalFleetd fleetd;
  RETURN_IF_ERROR(fleetd.Start(service));
  ServiceClient client(fleetd.grpc_address());
  Tokens tokens(client, service.admin_token);
  FollowServiceOptions follow;
  follow.uploader.server = fleetd.grpc_address();
  follow.robot_token = [&tokens](const std::string& robot) { return tokens.Of("robot:" + robot); };
  follow.engineer_token = tokens.Of("engineer:lifelong");
  if (follow.engineer_token.empty()) return slamcore::Internal("fleetd refused to mint an engineer token");
  if (name == "review") follow.review_every_runs = options.review_every_runs;
  FollowService(follow, fleet);
  auto statistics = SimulateFleet(fleet, progress);
  fleetd.Stop();
  RETURN_IF_ERROR(statistics.status());
  return Summarise(name, std::move(statistics).value(), options.runs);
}

const char* Outcome(const RunHealth& run) {
  return run.map.corrupted ? "corrupted" : run.repairs_taken > 0 ? "repaired" : "healthy";
}

double Round(double value, double unit) { return std::round(value / unit) * unit; }

// The share of each home's true floor its robot's map knows after the last run, averaged over robots: a
// repair that cut real floor shows here, not in the corrupted share.
double KnownFloorShare(const RegimeResult& result) {
  double share = 0.0;
  int robots = 0;
  for (const auto& robot : result.statistics.health) {
    if (robot.empty() || !(robot.back().map.home_floor_m2 > 0.0)) continue;
    share += robot.back().map.known_floor_m2 / robot.back().map.home_floor_m2;
    ++robots;
  }
  return robots > 0 ? share / robots : 0.0;
}

}  // namespace

slamcore::Status ValidateLifelong(const LifelongOptions& options) {
  if (options.worlds.empty()) return slamcore::InvalidArgument("--world: no homes to simulate");
  if (options.robots < 1 || options.robots > kMaxLifelongRobots) {
    return slamcore::InvalidArgument("--robots: expected 1.." + std::to_string(kMaxLifelongRobots) +
                                     ", got " + std::to_string(options.robots));
  }
  if (options.runs < 1 || options.runs > kMaxLifelongRuns) {
    return slamcore::InvalidArgument("--runs: expected 1.." + std::to_string(kMaxLifelongRuns) + ", got " +
                                     std::to_string(options.runs));
  }
  if (!(options.run_minutes > 0 && options.run_minutes <= 120)) {
    return slamcore::InvalidArgument("--minutes: expected more than 0 and at most 120");
  }
  if (options.review_every_runs < 1 || options.review_every_runs > kMaxLifelongRuns) {
    return slamcore::InvalidArgument("--review-every: expected 1.." + std::to_string(kMaxLifelongRuns) +
                                     " runs");
  }
  if (!(options.min_severity >= 0.0 && options.min_severity <= 1.0)) {
    return slamcore::InvalidArgument("--min-severity: expected 0..1");
  }
  if (options.protrusions != "any" && options.protrusions != "views") {
    return slamcore::InvalidArgument("--cut-protrusions: expected any or views, got \"" +
                                     options.protrusions + "\"");
  }
  if (options.regimes.empty()) return slamcore::InvalidArgument("--regimes: name at least one regime");
  for (const std::string& regime : options.regimes) {
    if (!KnownRegime(regime)) {
      return slamcore::InvalidArgument("--regimes: \"" + regime +
                                       "\" is not one of none, filter, service, review");
    }
  }
  return options.params.Validate();
}

slamcore::Result<std::vector<RegimeResult>> RunLifelong(
    const LifelongOptions& options, const std::function<void(const std::string&, int, int)>& progress,
    const std::function<void(const std::vector<RegimeResult>&)>& regime_done) {
  RETURN_IF_ERROR(ValidateLifelong(options));
  std::vector<RegimeResult> results;
  for (const std::string& regime : options.regimes) {
    if (progress) progress(regime, 0, options.robots * options.runs);  // the regime has started
    auto result = RunRegime(options, regime, [&](int done, int total) {
      if (progress) progress(regime, done, total);
    });
    if (!result.ok()) {
      return slamcore::Status(result.status().code(), "regime " + regime + ": " + result.status().message());
    }
    results.push_back(std::move(result).value());
    if (regime_done) regime_done(results);
  }
  return results;
}

std::string LifelongJson(const LifelongOptions& options, const std::vector<RegimeResult>& results) {
  nlohmann::json regimes = nlohmann::json::object();
  for (const RegimeResult& result : results) {
    nlohmann::json robots = nlohmann::json::array();
    for (const auto& robot : result.statistics.health) {
      nlohmann::json runs = nlohmann::json::array();
      for (const RunHealth& run : robot) {
        runs.push_back({Round(run.map.trajectory_rmse_m, 0.001), Round(run.map.false_free_m2, 0.01),
                        run.map.components, run.repairs_taken, Outcome(run),
                        Round(run.map.known_floor_m2, 0.01)});
      }
      robots.push_back(std::move(runs));
    }
    nlohmann::json by_run = nlohmann::json::array();
    for (const double share : result.corrupted_by_run) by_run.push_back(Round(share, 0.0001));
    regimes[result.name] = {{"corrupted_share", Round(result.corrupted_share, 0.0001)},
                            {"corrupted_by_run", by_run},
                            {"robots_ever_corrupted", result.robots_ever_corrupted},
                            {"mean_runs_to_corruption", Round(result.mean_runs_to_corruption, 0.01)},
                            {"runs_lost", result.runs_lost},
                            {"known_floor_share", Round(KnownFloorShare(result), 0.0001)},
                            {"repairs_taken", result.repairs_taken},
                            {"robots_healthy", result.statistics.robots_healthy},
                            {"robots_repaired", result.statistics.robots_repaired},
                            {"robots_corrupted", result.statistics.robots_corrupted},
                            {"recovery_accepted", result.statistics.recovery_accepted},
                            {"merge_accepted", result.statistics.merge_accepted},
                            {"wall_seconds", Round(result.seconds, 0.01)},
                            {"per_robot", robots}};
  }
  // The regimes run in the order named, so the first results.size() of them are done.
  const auto finished = static_cast<std::ptrdiff_t>(std::min(results.size(), options.regimes.size()));
  const nlohmann::json out = {
      {"robots", options.robots},
      {"runs", options.runs},
      {"seed", options.seed},
      {"minutes", options.run_minutes},
      {"review_every_runs", options.review_every_runs},
      {"min_severity", options.min_severity},
      {"cut_protrusions", options.protrusions},
      {"threshold",
       {{"trajectory_rmse_m", options.corruption.trajectory_rmse_m},
        {"false_free_m2", options.corruption.false_free_m2}}},
      {"per_robot_fields",
       {"trajectory_rmse_m", "false_free_m2", "components", "repairs_taken", "outcome", "known_floor_m2"}},
      {"regimes", regimes},
      {"regimes_to_come",
       std::vector<std::string>(options.regimes.begin() + finished, options.regimes.end())}};
  return out.dump();
}

std::string LifelongText(const LifelongOptions& options, const std::vector<RegimeResult>& results) {
  std::string text;
  char line[512];
  std::snprintf(
      line, sizeof line,
      "lifelong: %d robots x %d runs of %.0f min, seed %llu; corrupted = trajectory RMSE > %.2f m or false "
      "free area > %.2f m2\n",
      options.robots, options.runs, options.run_minutes, static_cast<unsigned long long>(options.seed),
      options.corruption.trajectory_rmse_m, options.corruption.false_free_m2);
  text += line;
  text +=
      "regime    corrupted after last run  ever corrupted  mean runs to corruption  runs lost  repairs taken "
      " true floor known  wall s\n";
  for (const RegimeResult& r : results) {
    std::snprintf(line, sizeof line, "%-9s %23.1f %%  %14d  %23.1f  %9d  %13d  %14.1f %%  %6.0f\n",
                  r.name.c_str(), 100 * r.corrupted_share, r.robots_ever_corrupted, r.mean_runs_to_corruption,
                  r.runs_lost, r.repairs_taken, 100 * KnownFloorShare(r), r.seconds);
    text += line;
  }
  text += "corrupted share by run:\nrun     ";
  for (const RegimeResult& r : results) {
    std::snprintf(line, sizeof line, " %8s", r.name.c_str());
    text += line;
  }
  text += "\n";
  const int step = std::max(1, options.runs / 10);
  for (int k = 0; k < options.runs; ++k) {
    if ((k + 1) % step != 0 && k != options.runs - 1) continue;
    std::snprintf(line, sizeof line, "%-8d", k + 1);
    text += line;
    for (const RegimeResult& r : results) {
      std::snprintf(line, sizeof line, " %7.1f%%", 100 * r.corrupted_by_run[static_cast<std::size_t>(k)]);
      text += line;
    }
    text += "\n";
  }
  return text;
}

}  // namespace sim
