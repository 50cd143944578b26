// Issue 18, "queries at fleet scale": the fleet's read queries at a baseline fleet size and at larger ones,
// on SQLite and on PostgreSQL, printed as time ratios against the baseline measured in the same run.
//
// The generator writes synthetic runs with reports of two parameter sets straight into storage in batched
// transactions (Repository::InsertRuns / PutReports, the same code a report write takes, roll-up included):
// a fleet of --robots robots (500: the load test's fleet) over --days days (365), four firmware versions,
// three models, so a larger fleet is more runs per robot and day. Each query is timed through FleetQueries
// (what both transports call) as the median of --repeats calls; the robots page as the dashboard's
// /api/robots reads it (a page of 100 robots with their histories in brief, one read), beside the way it read
// them before (every robot, then each robot's whole history), the baseline. Every tenth run of a robot also
// leaves a map version (mostly approved, some stale, a few pending), so histories grow with the fleet's runs;
// a robot's current version (what it reads before every run) is timed beside the whole-history read it
// replaced.
//
//   bin/query_scale_bench [--sizes 5000,500000] [--backends sqlite,postgres] [--repeats 15]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "server/fleet_queries.h"
#include "server/map_history.h"
#include "storage/repository.h"
#include "test_databases.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Options {
  std::vector<long> sizes = {5000, 500000};
  std::vector<std::string> backends = {"sqlite", "postgres"};
  int robots = 500, days = 365, repeats = 15;
};

std::vector<std::string> Split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) out.push_back(item);
  return out;
}

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

void Check(const storage::Status& status, const char* what) {
  if (!status.ok()) {
    std::fprintf(stderr, "%s: %s\n", what, status.ToString().c_str());
    std::exit(1);
  }
}

/// Every tenth run of a robot leaves a map version of it, as fleets make them: robots' own uploads are
/// approved, 1 in 7 is stale (built on a map the robot no longer ran), and one robot in 25 has a version still
/// waiting for an engineer's review (an early repair nobody looked at).
void AppendVersions(storage::Repository& repo, const std::vector<storage::RunRecord>& runs,
                    const std::string& snapshot) {
  for (const storage::RunRecord& run : runs) {
    const long index = std::stol(run.run_id.substr(4));
    if (index % 10 != 0) continue;
    const long robot = std::stol(run.robot_id.substr(6));
    storage::MapVersionRecord version;
    version.robot_id = run.robot_id;
    version.snapshot_id = snapshot;
    version.origin = storage::MapOrigin::kUpload;
    version.run_id = run.run_id;
    version.created_by = "robot:" + run.robot_id;
    version.approval = index == 30 && robot % 25 == 0 ? storage::MapApproval::kPending
                       : index % 70 == 50             ? storage::MapApproval::kStale
                                                      : storage::MapApproval::kApproved;
    Check(repo.AppendMapVersion(version, std::nullopt, {}).status(), "AppendMapVersion");
  }
}

constexpr long kWhatIfFirst = 4000;

/// Writes `count` runs (and their reports under "default" and "candidate", and for 1,000 of them under
/// "what-if") after the `already` written.
void Generate(storage::Repository& repo, const Options& options, long already, long count) {
  auto stored = repo.PutSnapshot("a map the bench's versions share");  // content-addressed: stored once
  Check(stored.status(), "PutSnapshot");
  const std::string snapshot = *stored;
  static const char* const kFirmware[] = {"fw-3.1", "fw-3.2", "fw-3.3", "fw-4.0"};
  static const char* const kModels[] = {"vac-s", "vac-m", "vac-l"};
  std::mt19937_64 random(static_cast<std::uint64_t>(already) + 1);
  std::uniform_int_distribution<int> small(0, 6);
  const std::int64_t start = 1735689600000;  // 2025-01-01
  constexpr long kBatch = 5000;
  std::vector<storage::RunRecord> runs;
  std::vector<storage::ReportBundle> reports;
  for (long i = already; i < already + count; ++i) {
    storage::RunRecord run;
    const int robot = static_cast<int>(i % options.robots);
    run.robot_id = "robot-" + std::to_string(robot);
    run.run_id = "run-" + std::to_string(i / options.robots);
    run.robot_model = kModels[robot % 3];
    const long day = (i * 7919) % options.days;  // spread over the year, every robot every few days
    run.firmware = kFirmware[std::min<long>(3, day * 4 / options.days + (robot % 2))];
    run.started_at_ms = start + day * 86400000 + (i % 86400) * 1000;
    run.ended_at_ms = run.started_at_ms + 600000;
    runs.push_back(run);
    // A what-if reprocessing of 1,000 runs (those of the first 5,000 numbered 4,000 on): a third set with a
    // report for those runs only, as a candidate tried on a slice of the fleet has.
    const bool reprocessed = i >= kWhatIfFirst && i < kWhatIfFirst + 1000;
    for (const char* set : {"default", "candidate", "what-if"}) {
      if (std::string(set) == "what-if" && !reprocessed) continue;
      storage::ReportBundle bundle;
      storage::ReportRecord& r = bundle.report;
      r.robot_id = run.robot_id;
      r.run_id = run.run_id;
      r.parameter_set = set;
      r.recovery_created = small(random);
      r.recovery_accepted = small(random) % 2;
      r.merge_created = small(random);
      r.merge_conditionally_accepted = small(random) % 3;
      r.merge_conditional_then_rejected = small(random) % 2;
      r.views_total = 40 + small(random);
      r.views_ambiguous = small(random);
      r.started_localized = small(random) % 2 == 0;
      r.protrusions_found = small(random) % 2;
      r.report = "synthetic";
      reports.push_back(std::move(bundle));
    }
    if (static_cast<long>(runs.size()) == kBatch || i + 1 == already + count) {
      Check(repo.InsertRuns(runs), "InsertRuns");
      AppendVersions(repo, runs, snapshot);
      for (std::size_t from = 0; from < reports.size(); from += kBatch) {
        const auto to = std::min(reports.size(), from + kBatch);
        Check(repo.PutReports({reports.begin() + static_cast<std::ptrdiff_t>(from),
                               reports.begin() + static_cast<std::ptrdiff_t>(to)}),
              "PutReports");
      }
      runs.clear();
      reports.clear();
    }
  }
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

struct Query {
  const char* name;
  std::function<void()> call;
};

std::vector<Query> Queries(storage::Repository& repo, server::FleetQueries& queries) {
  const server::Principal engineer{"engineer:bench", server::Role::kEngineer, "bench"};
  const auto must = [](auto result, const char* what) {
    if (!result.ok()) Check(result.status(), what);
  };
  storage::RunFilter by_default;
  by_default.parameter_set = "default";
  return {
      {"statistics by day",
       [=, &queries] { must(queries.Statistics(engineer, by_default, storage::GroupBy::kDay), "by day"); }},
      {"statistics by firmware",
       [=, &queries] {
         must(queries.Statistics(engineer, by_default, storage::GroupBy::kFirmware), "by firmware");
       }},
      {"statistics by parameter set",
       [=, &queries] { must(queries.Statistics(engineer, {}, storage::GroupBy::kParameterSet), "by set"); }},
      {"runs page (25, with reports)",
       [=, &queries] {
         server::RunsQuery query;
         query.page_size = 25;
         query.report_set = "default";
         query.with_regions = true;
         must(queries.Runs(engineer, query), "runs page");
       }},
      {"robots page (100 robots, one read)",
       [&repo] {
         storage::RobotSummaryQuery page;
         page.limit = 100;
         auto robots = repo.ListRobotSummaries(page);
         if (!robots.ok()) Check(robots.status(), "robots page");
       }},
      {"robots page, before (every history)",
       [&repo] {
         auto robots = repo.ListRobots();
         if (!robots.ok()) Check(robots.status(), "robots");
         for (const auto& robot : *robots) {
           auto versions = repo.ListMapVersions(robot.robot_id);
           if (!versions.ok()) Check(versions.status(), "map versions");
         }
       }},
      // What a robot reads before every run (Maps.GetMap's lookup), for a robot whose history grows with the
      // fleet, beside the whole-history read it replaced.
      {"robot's current map version",
       [&repo] {
         server::MapHistory history(repo, server::MapPolicy{});
         auto current = history.Get("robot-7", 0);
         if (!current.ok()) Check(current.status(), "current version");
       }},
      {"robot's current map version, before (history)",
       [&repo] {
         auto versions = repo.ListMapVersions("robot-7");
         if (!versions.ok()) Check(versions.status(), "map versions");
         const auto current = std::find_if(versions->rbegin(), versions->rend(), [](const auto& version) {
           return version.approval == storage::MapApproval::kApproved;
         });
         if (current == versions->rend()) Check(storage::NotFound("no current version"), "current version");
         auto findings = repo.ListMapFindings("robot-7", current->version);
         if (!findings.ok()) Check(findings.status(), "findings");
         auto metadata = repo.GetMapMetadata("robot-7", current->version);
         if (!metadata.ok()) Check(metadata.status(), "metadata");
       }},
      {"compare default vs candidate",
       [=, &queries] { must(queries.Compare(engineer, {}, "default", "candidate", 15), "compare"); }},
      {"compare default vs what-if (1,000 runs)",
       [=, &queries] { must(queries.Compare(engineer, {}, "default", "what-if", 15), "compare what-if"); }},
  };
}

void PrintTable(const std::string& backend, const Options& options, const std::vector<long>& sizes,
                const std::map<std::string, std::vector<double>>& times) {
  std::printf("\n%s, %d robots, %d days; median of %d calls; ratio = time / time at %ld runs\n",
              backend.c_str(), options.robots, options.days, options.repeats, sizes.front());
  std::printf("%-48s", "query");
  for (const long size : sizes) std::printf(" %10ld runs", size);
  std::printf("   ratio\n");
  for (const auto& [name, medians] : times) {
    std::printf("%-48s", name.c_str());
    for (double seconds : medians) std::printf(" %12.2f ms", seconds * 1e3);
    std::printf("   %5.2f\n", medians.back() / medians.front());
  }
  std::printf("\n");
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--sizes") {
      options.sizes.clear();
      for (const auto& size : Split(value)) options.sizes.push_back(std::stol(size));
    } else if (flag == "--backends") {
      options.backends = Split(value);
    } else if (flag == "--repeats") {
      options.repeats = std::stoi(value);
    } else if (flag == "--robots") {
      options.robots = std::stoi(value);
    } else {
      std::fprintf(stderr, "unknown flag %s (--sizes, --backends, --repeats, --robots)\n", flag.c_str());
      return 2;
    }
  }
  std::sort(options.sizes.begin(), options.sizes.end());
  for (const std::string& backend : options.backends) {
    auto url = storage::testing::NewDatabaseUrl(backend == "postgres" ? storage::testing::Backend::kPostgres
                                                                      : storage::testing::Backend::kSqlite);
    Check(url.status(), "database");
    auto repo = storage::OpenRepository(*url);
    Check(repo.status(), "open");
    storage::Repository& repository = **repo;
    for (const char* set : {"default", "candidate", "what-if"})
      Check(repository.PutParameterSet({set, set}).status(), "set");
    for (int robot = 0; robot < options.robots; ++robot) {
      Check(repository.PutRobot({"robot-" + std::to_string(robot), "vac-s", "fw-3.1", 1}), "robot");
    }
    server::FleetQueries queries(repository, "default");
    std::map<std::string, std::vector<double>> times;  // query → median seconds per size
    long written = 0;
    for (const long size : options.sizes) {
      const auto started = Clock::now();
      Generate(repository, options, written, size - written);
      std::printf("%s: generated %ld runs (%ld reports) in %.1f s\n", backend.c_str(), size - written,
                  2 * (size - written), Seconds(started));
      std::fflush(stdout);
      written = size;
      for (const Query& query : Queries(repository, queries)) {
        query.call();  // warm the caches once
        std::vector<double> samples;
        for (int i = 0; i < options.repeats; ++i) {
          const auto begin = Clock::now();
          query.call();
          samples.push_back(Seconds(begin));
        }
        times[query.name].push_back(Median(samples));
      }
      // The table so far after every size, so a long run that is stopped still leaves its numbers.
      const auto measured = static_cast<std::ptrdiff_t>(times.begin()->second.size());
      PrintTable(backend, options, {options.sizes.begin(), options.sizes.begin() + measured}, times);
    }
    std::printf("\n");
    repo->reset();
    if (url->rfind("sqlite:", 0) == 0) {  // the fleet's file is hundreds of MB: not left behind
      std::error_code ignored;
      std::filesystem::remove_all(std::filesystem::path(url->substr(7)).parent_path(), ignored);
    }
  }
  return 0;
}
