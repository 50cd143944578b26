#include "fleet_client/local_fleetd.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>

#include <nlohmann/json.hpp>

namespace fleet_client {
namespace {

std::string RandomHex(int bytes) {
  std::ifstream random("/dev/urandom", std::ios::binary);
  static const char* kDigits = "0123456789abcdef";
  std::string hex;
  for (int k = 0; k < bytes; ++k) {
    const auto byte = static_cast<unsigned char>(random.get());
    hex.push_back(kDigits[byte >> 4]);
    hex.push_back(kDigits[byte & 15]);
  }
  return hex;
}

}  // namespace

std::filesystem::path FleetdBesideThisProgram() {
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  return error ? std::filesystem::path("fleetd") : self.parent_path() / "fleetd";
}

std::string RandomToken(const std::string& principal) { return principal + "." + RandomHex(32); }

LocalFleetd::~LocalFleetd() { Stop(); }

slamcore::Status LocalFleetd::Start(const LocalFleetdOptions& options) {
  if (pid_ > 0) return slamcore::FailedPrecondition("fleetd is already running");
  grpc_.clear();
  http_.clear();
  const std::filesystem::path& binary = options.binary;
  if (access(binary.c_str(), X_OK) != 0) {
    return slamcore::FailedPrecondition("fleetd: " + binary.string() + " is not an executable");
  }
  std::error_code error;
  std::filesystem::create_directories(options.directory, error);
  if (error) return slamcore::FailedPrecondition(options.directory.string() + ": " + error.message());

  const std::vector<std::pair<std::string, std::string>> defaults = {
      {"--db", "sqlite:" + (options.directory / "fleet.db").string()},
      {"--listen", "127.0.0.1:0"},
      {"--http", "127.0.0.1:0"}};
  std::vector<std::string> args = {binary.string()};
  for (const auto& [flag, value] : defaults) {
    if (std::find(options.flags.begin(), options.flags.end(), flag) == options.flags.end()) {
      args.push_back(flag);
      args.push_back(value);
    }
  }
  args.insert(args.end(), options.flags.begin(), options.flags.end());
  std::vector<char*> argv;
  for (auto& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);
  log_path_ = options.directory / "fleetd.log";

  // Close-on-exec, so that a fleetd started meanwhile from another thread holds no copy of the write end (the
  // child's stdout, made by dup2, stays open).
  int out[2];
  if (pipe2(out, O_CLOEXEC) != 0) return slamcore::Internal("pipe failed");
  pid_ = fork();
  if (pid_ < 0) {
    close(out[0]);
    close(out[1]);
    return slamcore::Internal("fork failed");
  }
  if (pid_ == 0) {
    dup2(out[1], 1);
    const int log = ::open(log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (log < 0) _exit(126);
    dup2(log, 2);
    if (!options.admin_token.empty()) setenv("FLEETD_BOOTSTRAP_ADMIN_TOKEN", options.admin_token.c_str(), 1);
    if (options.in_child) options.in_child();
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(out[1]);
  std::string line;
  char c;
  while (read(out[0], &c, 1) == 1 && c != '\n' && line.size() < 4096) line += c;
  close(out[0]);
  try {
    const auto addresses = nlohmann::json::parse(line);
    grpc_ = addresses.at("grpc").get<std::string>();
    const auto http = addresses.find("http");  // null without an HTTP listener
    if (http != addresses.end() && http->is_string()) http_ = http->get<std::string>();
  } catch (const std::exception&) {
    Stop();
    return slamcore::FailedPrecondition("fleetd " + binary.string() + " did not start (see " +
                                        log_path_.string() +
                                        (line.empty() ? ")" : "; it printed \"" + line + "\")"));
  }
  return slamcore::Status::Ok();
}

int LocalFleetd::Stop() {
  if (pid_ <= 0) return -1;
  kill(pid_, SIGTERM);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace fleet_client
