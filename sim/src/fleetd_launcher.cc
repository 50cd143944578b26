#include "sim/fleetd_launcher.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>

#include <nlohmann/json.hpp>

namespace sim {
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

FleetdLauncher::~FleetdLauncher() { Stop(); }

slamcore::Status FleetdLauncher::Start(const std::filesystem::path& binary,
                                       const std::filesystem::path& directory,
                                       const std::vector<std::string>& extra) {
  if (pid_ > 0) return slamcore::FailedPrecondition("fleetd is already running");
  if (access(binary.c_str(), X_OK) != 0) {
    return slamcore::FailedPrecondition("fleetd: " + binary.string() +
                                        " is not an executable (build fleetd, or pass --fleetd)");
  }
  std::error_code error;
  std::filesystem::create_directories(directory, error);
  if (error) return slamcore::FailedPrecondition(directory.string() + ": " + error.message());
  admin_token_ = "admin:lifelong." + RandomHex(32);
  std::vector<std::string> args = {
      binary.string(), "--db",         "sqlite:" + (directory / "fleet.db").string(),
      "--listen",      "127.0.0.1:0",  "--http",
      "127.0.0.1:0",   "--log-format", "text"};
  args.insert(args.end(), extra.begin(), extra.end());
  const std::string log_path = (directory / "fleetd.log").string();
  int out[2];
  if (pipe(out) != 0) return slamcore::Internal("pipe failed");
  pid_ = fork();
  if (pid_ == 0) {
    dup2(out[1], 1);
    const int log = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (log >= 0) dup2(log, 2);
    close(out[0]);
    close(out[1]);
    setenv("FLEETD_BOOTSTRAP_ADMIN_TOKEN", admin_token_.c_str(), 1);
    std::vector<char*> argv;
    for (auto& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(out[1]);
  std::string line;
  char c;
  while (read(out[0], &c, 1) == 1 && c != '\n' && line.size() < 4096) line += c;
  close(out[0]);
  try {
    grpc_ = nlohmann::json::parse(line).at("grpc").get<std::string>();
  } catch (const std::exception&) {
    Stop();
    return slamcore::FailedPrecondition("fleetd " + binary.string() + " did not start (see " + log_path +
                                        ")");
  }
  return slamcore::Status::Ok();
}

bool FleetdLauncher::Stop() {
  if (pid_ <= 0) return false;
  kill(pid_, SIGTERM);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

}  // namespace sim
