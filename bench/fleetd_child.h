// The benchmarks' fleetd: a child process on loopback (gRPC port 0, no HTTP) with its SQLite file in
// `directory`, the bootstrap admin token from the environment, stderr to `directory`/fleetd.log, and the
// bound gRPC address read from stdout's first line. SIGTERM and wait on destruction.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace bench {

struct FleetdChild {
  int pid = -1;
  std::string grpc;  // empty when it did not start

  FleetdChild(const std::string& binary, const std::filesystem::path& directory,
              const std::string& admin_token, std::vector<std::string> extra) {
    std::vector<std::string> args = {binary,     "--db",        "sqlite:" + (directory / "fleet.db").string(),
                                     "--listen", "127.0.0.1:0", "--http",
                                     ""};
    args.insert(args.end(), extra.begin(), extra.end());
    int out[2];
    if (pipe(out) != 0) return;
    pid = fork();
    if (pid == 0) {
      dup2(out[1], 1);
      const std::string log = (directory / "fleetd.log").string();
      if (freopen(log.c_str(), "w", stderr) == nullptr) _exit(126);
      setenv("FLEETD_BOOTSTRAP_ADMIN_TOKEN", admin_token.c_str(), 1);
      std::vector<char*> argv;
      for (auto& arg : args) argv.push_back(arg.data());
      argv.push_back(nullptr);
      execv(argv[0], argv.data());
      _exit(127);
    }
    close(out[1]);
    std::string line;
    char c;
    while (read(out[0], &c, 1) == 1 && c != '\n') line += c;
    close(out[0]);
    try {
      grpc = nlohmann::json::parse(line).at("grpc").get<std::string>();
    } catch (const std::exception&) {}
  }
  ~FleetdChild() {
    if (pid > 0) {
      kill(pid, SIGTERM);
      waitpid(pid, nullptr, 0);
    }
  }
  FleetdChild(const FleetdChild&) = delete;
  FleetdChild& operator=(const FleetdChild&) = delete;
};

}  // namespace bench
