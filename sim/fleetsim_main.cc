// fleetsim: simulates a fleet of robots in real homes and prints the fleet statistics.
//
//   fleetsim --world DIR --robots N --runs M --seed S [--out DIR] [--minutes T] [--threads K] [--json]
//
// DIR holds floor plans (.txt) and/or map_server maps (.yaml); a single file works too. With --out, each
// run's telemetry is written as OUT/<robot>/<run_id>.runpb (fleet.v1.RunFile). With --json, the last line of
// stdout is one JSON object. Progress goes to stderr.
//
//   fleetsim ... --upload HOST:PORT --token T [--upload-threads K]
//
// also uploads every run to fleetd like a robot (fleet_client/upload_files.h: retries with backoff; runs of one
// robot in order, robots in parallel); the token comes from --token-file, FLEET_TOKEN_FILE, FLEET_TOKEN or --token.
//
//   fleetsim ... [--home-clutter typical|high] [--stuck-rate-scale X] [--lidar-share F] [--protrusion-data DIR]
//
// sets the homes' rugs and low furniture, scales the per-contact stuck probabilities, sets the share of robots
// with a lidar, and writes each run's parent/child maps with per-cell ground truth as a protrusion data set
// (docs/fleetsim.md).
//
//   fleetsim ... --params FILE
//
// runs the robots' on-board Mapper with a parameter set (JSON, fleet.v1.ParameterSet, as `slamtool replay-g2o
// --params` and fleetd take) instead of slamcore's defaults: a candidate set tried on a simulated fleet.
//
//   fleetsim --lifelong --world DIR [--robots N] [--runs M] [--seed S] [--minutes T] [--json] [--results FILE]
//            [--regimes none,filter,service,review] [--review-every K] [--min-severity X]
//            [--cut-protrusions any|views] [--fleetd BIN]
//
// the lifelong experiment (sim/lifelong.h; default 20 robots × 40 runs of 10 minutes): the four regimes on the
// same seeds, a fleetd of its own for the service regimes (the one beside this program unless --fleetd), a
// table (or with --json one object on the last line), --results also writes that object to FILE.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <unistd.h>
#include <iostream>

#include "analyzer/parameters.h"
#include "fleet_client/local_fleetd.h"
#include "fleet_client/upload_files.h"
#include "fleet_client/uploader.h"
#include "sim/fleet.h"
#include "sim/follow_service.h"
#include "sim/lifelong.h"
#include "slamcore/graph_io.h"

namespace {

/// The home files of `world` (a directory, or one file); false after printing why there are none.
bool HomesOf(const std::string& world, std::vector<std::filesystem::path>* homes) {
  if (!std::filesystem::is_directory(world)) {
    *homes = {world};
    return true;
  }
  auto worlds = sim::ListWorlds(world);
  if (!worlds.ok()) {
    std::cerr << "fleetsim: " << worlds.status().ToString() << "\n";
    return false;
  }
  *homes = std::move(worlds).value();
  return true;
}

/// Writes `object` to `path` whole or not at all (slamcore::WriteFileReplacing); false with a message on
/// stderr when it cannot.
bool WriteResults(const std::string& path, const std::string& object) {
  const slamcore::Status written =
      slamcore::WriteFileReplacing(path, [&](std::ostream& out) { out << object << "\n"; });
  if (!written.ok()) std::cerr << "fleetsim: --results: " << written.message() << "\n";
  return written.ok();
}

/// "42 s", "3 min 05 s", "2 h 07 min": the time a regime has run, on the progress line.
std::string ElapsedText(long long seconds) {
  char text[48];
  if (seconds < 60) {
    std::snprintf(text, sizeof text, "%lld s", seconds);
  } else if (seconds < 3600) {
    std::snprintf(text, sizeof text, "%lld min %02lld s", seconds / 60, seconds % 60);
  } else {
    std::snprintf(text, sizeof text, "%lld h %02lld min", seconds / 3600, seconds / 60 % 60);
  }
  return text;
}

/// --lifelong: validates, runs the regimes with one updating progress line on stderr, prints the table or the
/// JSON object, and writes the object to `results_file` (whole or not at all) after each regime, so that the
/// regimes done survive a later one's failure or a stop (regimes_to_come names the others).
int RunLifelongCommand(const std::string& world, sim::LifelongOptions& options, bool json,
                       const std::string& results_file, bool remove_work_dir) {
  if (!HomesOf(world, &options.worlds)) return 1;
  if (const slamcore::Status valid = sim::ValidateLifelong(options); !valid.ok()) {
    std::cerr << "fleetsim: " << valid.message() << "\n";
    return 2;
  }
  // The line also says how long the regime has run: the unprotected one slows as its maps grow and can
  // take hours at the default size, so a rate read off the first runs would promise too much. Each regime
  // announces itself with done = 0 as it starts.
  auto regime_start = std::chrono::steady_clock::now();
  const auto results = sim::RunLifelong(
      options,
      [&](const std::string& regime, int done, int total) {
        const auto now = std::chrono::steady_clock::now();
        if (done == 0) regime_start = now;
        const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(now - regime_start).count();
        std::fprintf(stderr, "\rfleetsim lifelong: regime %-8s %5d/%d runs, %-10s", regime.c_str(), done,
                     total, ElapsedText(seconds).c_str());
        std::fflush(stderr);
      },
      [&](const std::vector<sim::RegimeResult>& so_far) {
        // A failed write says so on stderr; the next regime's (or the final) write tries again.
        if (!results_file.empty() && so_far.size() < options.regimes.size())
          (void)WriteResults(results_file, sim::LifelongJson(options, so_far));
      });
  std::fprintf(stderr, "\n");
  if (remove_work_dir) {
    std::error_code ignored;
    std::filesystem::remove_all(options.work_dir, ignored);
  }
  if (!results.ok()) {
    std::cerr << "fleetsim: " << results.status().ToString() << "\n";
    return 1;
  }
  const std::string object = sim::LifelongJson(options, *results);
  if (!results_file.empty() && !WriteResults(results_file, object)) return 1;
  std::cout << (json ? object + "\n" : sim::LifelongText(options, *results));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"fleetsim: a simulated fleet of real homes and robots, with ground truth"};
  std::string world;
  sim::FleetOptions options;
  std::string out;
  bool upload_staging = false;  // out is a temporary directory of this process, for --upload only
  bool json = false;
  app.add_option("--world", world, "directory of floor plans (.txt) and maps (.yaml), or one such file")
      ->required();
  app.add_option("--robots", options.robots, "robots")->check(CLI::Range(1, 100000));
  app.add_option("--runs", options.runs, "runs per robot")->check(CLI::Range(1, 100000));
  app.add_option("--seed", options.seed, "seed: the same seed gives the same fleet");
  app.add_option("--out", out, "write each run's telemetry here");
  app.add_option("--minutes", options.params.run_minutes, "simulated minutes per run")
      ->check(CLI::PositiveNumber);
  app.add_option("--threads", options.threads, "worker threads (0: all cores)")
      ->check(CLI::NonNegativeNumber);
  std::string clutter = "typical", protrusion_data;
  app.add_option("--home-clutter", clutter, "rugs and low furniture in the homes: typical or high")
      ->check(CLI::IsMember({"typical", "high"}));
  app.add_option("--stuck-rate-scale", options.params.stuck_rate_scale,
                 "multiplies the per-contact probabilities of getting stuck (0: never)")
      ->check(CLI::Range(0.0, 1000.0));
  app.add_option("--lookalike-pass-seconds", options.params.lookalike_pass_gap_seconds,
                 "a look-alike taken for a landmark is taken for the whole pass: recognitions less than this "
                 "apart (0: each recognition draws its own, the default)")
      ->check(CLI::Range(0.0, 600.0));
  app.add_option("--lidar-free-range", options.params.lidar_free_range,
                 "metres along a ray that a lidar's patch marks free (0: its whole range, the default)")
      ->check(CLI::Range(0.0, 20.0));
  app.add_option("--lidar-share", options.params.lidar_share,
                 "share of robots with a lidar (the rest: a front ToF)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--protrusion-data", protrusion_data,
                 "write each run's parent/child maps with per-cell truth here (protrusion data-set layout)");
  app.add_flag("--json", json, "print the statistics as one JSON object on the last line");
  std::string params_file;
  app.add_option(
         "--params", params_file,
         "the robots' on-board Mapper parameter set (JSON, fleet.v1.ParameterSet; not with --lifelong, "
         "whose regimes set their own)")
      ->check(CLI::ExistingFile);
  fleet_client::UploadFilesOptions upload;
  app.add_option("--upload", upload.uploader.server, "also upload every run to this fleetd (host:port)");
  std::string token_file;
  app.add_option("--token", upload.uploader.token,
                 "token for --upload (default: $FLEET_TOKEN); prefer --token-file or the environment");
  app.add_option("--token-file", token_file,
                 "read the token for --upload from this file (default $FLEET_TOKEN_FILE)");
  app.add_option("--upload-threads", upload.threads, "parallel upload streams")->check(CLI::Range(1, 256));
  bool follow = false;
  app.add_flag(
      "--follow-service", follow,
      "with --upload: each robot uploads after each run and takes the newest approved map before the next");
  app.add_flag(
      "--map-health", options.measure_map_health,
      "measure every robot's map against ground truth after each run (docs/fleetsim.md, Map health)");
  bool lifelong = false;
  sim::LifelongOptions life;
  std::string regimes = "none,filter,service,review", results_file, fleetd, work_dir;
  app.add_flag("--lifelong", lifelong,
               "the lifelong experiment: four regimes side by side (docs/fleetsim.md)");
  app.add_option("--regimes", regimes, "--lifelong: the regimes to run, comma-separated");
  app.add_option("--review-every", life.review_every_runs,
                 "--lifelong review: an engineer approves every K runs");
  app.add_option("--min-severity", life.min_severity,
                 "--lifelong: the repair policy acts on findings this severe");
  app.add_option("--cut-protrusions", life.protrusions,
                 "--lifelong: which protrusion findings the policy cuts: any, or views (those the run's own "
                 "views show; the map-only model's calls wait for review)")
      ->capture_default_str();
  app.add_option("--results", results_file, "--lifelong: also write the JSON object to this file");
  app.add_option("--fleetd", fleetd, "--lifelong: the fleetd binary (default: beside fleetsim)");
  app.add_option("--work-dir", work_dir,
                 "--lifelong: where the service regimes' fleetd keep their databases");
  CLI11_PARSE(app, argc, argv);
  if (!params_file.empty()) {
    if (lifelong) {
      std::cerr << "fleetsim: --params: not with --lifelong, whose regimes set the robots' parameters\n";
      return 2;
    }
    const auto mapper = analyzer::ReadMapperParamsFile(params_file);
    if (!mapper.ok()) {
      std::cerr << "fleetsim: --params: " << mapper.status().ToString() << "\n";
      return 2;
    }
    options.params.mapper = *mapper;
  }
  if (lifelong) {
    life.robots = app.count("--robots") ? options.robots : 20;
    life.runs = app.count("--runs") ? options.runs : 40;
    life.seed = options.seed;
    life.threads = options.threads;
    life.run_minutes = app.count("--minutes") ? options.params.run_minutes : 10.0;
    life.params = options.params;
    life.params.home_clutter = *sim::ParseHomeClutter(clutter);
    life.regimes.clear();
    for (std::size_t start = 0; start <= regimes.size();) {
      const std::size_t comma = std::min(regimes.find(',', start), regimes.size());
      if (comma > start) life.regimes.push_back(regimes.substr(start, comma - start));
      start = comma + 1;
    }
    life.fleetd = fleetd.empty() ? fleet_client::FleetdBesideThisProgram() : std::filesystem::path(fleetd);
    life.work_dir = work_dir.empty() ? std::filesystem::temp_directory_path() /
                                           ("fleetsim-lifelong-" + std::to_string(getpid()))
                                     : std::filesystem::path(work_dir);
    return RunLifelongCommand(world, life, json, results_file, work_dir.empty());
  }
  if (follow && upload.uploader.server.empty()) {
    std::cerr << "fleetsim: --follow-service needs --upload HOST:PORT\n";
    return 2;
  }
  options.params.home_clutter = *sim::ParseHomeClutter(clutter);  // checked by IsMember above
  options.protrusion_data = protrusion_data;

  if (!HomesOf(world, &options.worlds)) return 1;
  if (!upload.uploader.server.empty()) {
    if (token_file.empty() && std::getenv("FLEET_TOKEN_FILE") != nullptr)
      token_file = std::getenv("FLEET_TOKEN_FILE");
    if (!token_file.empty()) {
      std::string error;
      auto token = fleet_client::ReadTokenFile(token_file, &error);
      if (!token) {
        std::cerr << "fleetsim: " << error << "\n";
        return 2;
      }
      upload.uploader.token = *token;
    }
    if (upload.uploader.token.empty() && std::getenv("FLEET_TOKEN") != nullptr)
      upload.uploader.token = std::getenv("FLEET_TOKEN");
    if (out.empty() && !follow) {
      out = (std::filesystem::temp_directory_path() / ("fleetsim-" + std::to_string(getpid()))).string();
      upload_staging = true;
    }
  }
  if (follow) {
    sim::FollowServiceOptions follow_options;
    follow_options.uploader = upload.uploader;
    sim::FollowService(follow_options, options);
  }
  options.out = out;
  const auto remove_staged_runs = [&] {
    std::error_code ignored;
    if (upload_staging) std::filesystem::remove_all(out, ignored);
  };
  const bool interactive = isatty(fileno(stderr));
  const auto statistics = sim::SimulateFleet(options, [interactive](int done, int total) {
    if (interactive) {
      const int width = 40, filled = width * done / total;
      std::fprintf(stderr, "\r[%.*s%*s] %d/%d runs", filled, "########################################",
                   width - filled, "", done, total);
      if (done == total) std::fprintf(stderr, "\n");
    } else if (done == total || done % std::max(1, total / 10) == 0) {
      std::fprintf(stderr, "fleetsim: %d/%d runs\n", done, total);
    }
  });
  if (!statistics.ok()) {
    std::cerr << "fleetsim: " << statistics.status().ToString() << "\n";
    remove_staged_runs();
    return 1;
  }
  if (!upload.uploader.server.empty() && !follow) {
    const auto uploaded = fleet_client::UploadFiles({out}, upload);
    std::fprintf(stderr, "fleetsim: %s\n", uploaded.Summary().c_str());
    if (uploaded.failed > 0) {
      if (upload_staging)
        std::fprintf(stderr, "fleetsim: the runs are kept in %s for a retry\n", out.c_str());
      return 1;
    }
    // Runs staged only for this upload are gone once the server has them (with --out they are the user's).
    remove_staged_runs();
  }
  if (json) {
    std::cout << statistics->ToJson() << "\n";
  } else {
    std::cout << statistics->ToText();
  }
  return 0;
}
