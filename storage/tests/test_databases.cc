#include "test_databases.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <pqxx/pqxx>
#include <random>
#include <vector>

#include "status_matchers.h"

namespace storage::testing {
namespace fs = std::filesystem;

namespace {

const char* const kPostgresBin = "/usr/lib/postgresql/15/bin";

std::string MakeTempDir(const std::string& prefix) {
  std::string pattern = (fs::temp_directory_path() / (prefix + "XXXXXX")).string();
  if (mkdtemp(pattern.data()) == nullptr) return {};
  return pattern;
}

int FreeLoopbackPort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof(address);
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0) {
    port = ntohs(address.sin_port);
  }
  close(fd);
  return port;
}

/// The throwaway server, started on first use and stopped when the test process exits.
class PostgresTestServer {
 public:
  static Result<PostgresTestServer*> Instance() {
    static std::mutex mutex;
    static std::unique_ptr<PostgresTestServer> server;
    static Status failure;
    std::lock_guard<std::mutex> lock(mutex);
    if (!server && failure.ok()) {
      auto started = std::make_unique<PostgresTestServer>();
      failure = started->Start();
      if (failure.ok()) server = std::move(started);
    }
    RETURN_IF_ERROR(failure);
    return server.get();
  }

  ~PostgresTestServer() {
    if (getpid() != owner_pid_ || dir_.empty()) return;  // forked children must not stop the server
    if (started_)
      Run(AsPostgres(std::string(kPostgresBin) + "/pg_ctl -D " + dir_ + "/data -m immediate -w stop"));
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }

  Result<std::string> NewDatabase() {
    const std::string name = "contract_" + std::to_string(next_database_++);
    try {
      pqxx::connection admin(AdminUrl("postgres"));
      pqxx::nontransaction create(admin);
      // FILE_COPY: with fsync off, copying files beats WAL-logging every block (the PG 15 default).
      create.exec("CREATE DATABASE " + name + " STRATEGY FILE_COPY");  // our own generated name, not input
    } catch (const std::exception& error) {
      return Internal(std::string("cannot create test database: ") + error.what());
    }
    return AdminUrl(name);
  }

  Status Start() {
    if (!fs::exists(std::string(kPostgresBin) + "/initdb") ||
        !fs::exists(std::string(kPostgresBin) + "/pg_ctl")) {
      return FailedPrecondition(std::string("PostgreSQL 15 server binaries not found in ") + kPostgresBin +
                                "; run deploy/bootstrap.sh (package postgresql)");
    }
    dir_ = MakeTempDir("storage_pg_");
    if (dir_.empty()) return Internal("cannot create a temp dir for PostgreSQL");
    if (geteuid() == 0 && Run("chown postgres:postgres " + dir_) != 0) {
      return Internal("cannot chown " + dir_ + " to the postgres user");
    }
    port_ = FreeLoopbackPort();
    const std::string log = dir_ + "/server.log";
    if (Run(AsPostgres(std::string(kPostgresBin) + "/initdb -D " + dir_ +
                       "/data -U postgres -A trust -E UTF8 --no-locale --no-sync > " + dir_ +
                       "/initdb.log 2>&1")) != 0) {
      return Internal("initdb failed; see " + dir_ + "/initdb.log");
    }
    if (Run(AsPostgres(
            std::string(kPostgresBin) + "/pg_ctl -D " + dir_ + "/data -l " + log +
            " -w -t 30 start -o \"-c listen_addresses=127.0.0.1 -p " + std::to_string(port_) + " -k " + dir_ +
            " -c fsync=off -c synchronous_commit=off -c full_page_writes=off -c max_connections=200\"" +
            " > /dev/null")) != 0) {
      std::ifstream in(log);
      std::string text, line;
      while (std::getline(in, line)) text += line + "\n";
      return Internal("pg_ctl start failed: " + text);
    }
    started_ = true;
    return Status::Ok();
  }

 private:
  static int Run(const std::string& command) { return std::system(command.c_str()); }
  static std::string AsPostgres(const std::string& command) {
    return geteuid() == 0 ? "runuser -u postgres -- " + command : command;
  }
  std::string AdminUrl(const std::string& database) const {
    return "postgresql://postgres@127.0.0.1:" + std::to_string(port_) + "/" + database;
  }

  const pid_t owner_pid_ = getpid();
  std::string dir_;
  int port_ = 0;
  bool started_ = false;
  std::atomic<int> next_database_{0};
};

std::string Telemetry(const std::string& seed, std::size_t bytes) {
  std::mt19937_64 random(std::hash<std::string>{}(seed));
  std::string out(bytes, '\0');
  for (std::size_t i = 0; i < bytes; ++i) {
    // Half noise, half structure: compressible like real telemetry, with NUL bytes in it.
    out[i] = (i % 2 == 0) ? static_cast<char>(random() & 0xFF) : static_cast<char>(i % 7);
  }
  return out;
}

}  // namespace

std::string BackendName(const ::testing::TestParamInfo<Backend>& info) {
  return info.param == Backend::kSqlite ? "Sqlite" : "Postgres";
}

Result<std::string> NewDatabaseUrl(Backend backend) {
  if (backend == Backend::kSqlite) {
    static std::atomic<int> counter{0};
    const std::string dir = MakeTempDir("storage_sqlite_");
    if (dir.empty()) return Internal("cannot create a temp dir");
    // A test that opens its own database by URL does not remove it; the process does, when it ends.
    static struct RemovedAtExit {
      std::mutex mutex;
      std::vector<std::string> dirs;
      ~RemovedAtExit() {
        std::error_code ignored;
        for (const std::string& path : dirs) fs::remove_all(path, ignored);
      }
    } created;
    {
      std::lock_guard lock(created.mutex);
      created.dirs.push_back(dir);
    }
    return "sqlite:" + dir + "/fleet" + std::to_string(counter++) + ".db";
  }
  ASSIGN_OR_RETURN(auto server, PostgresTestServer::Instance());
  return (server)->NewDatabase();
}

void BackendTest::SetUp() {
  auto url = NewDatabaseUrl(GetParam());
  ASSERT_THAT(url, IsOk());
  url_ = *url;
  Reopen();
}

void BackendTest::TearDown() {
  repo_.reset();
  if (url_.rfind("sqlite:", 0) == 0) {
    std::error_code ignored;
    fs::remove_all(fs::path(url_.substr(7)).parent_path(), ignored);
  }
}

void BackendTest::Reopen() {
  repo_.reset();
  auto opened = internal::OpenSqlRepository(url_, OpenOptions{});
  ASSERT_THAT(opened, IsOk());
  repo_ = std::move(opened).value();
}

internal::SqlRows BackendTest::RawQuery(const std::string& sql,
                                        const std::vector<internal::SqlValue>& params) {
  internal::SqlRows rows;
  Status status = repo_->database().InTransaction(
      internal::TransactionMode::kWrite, [&](internal::SqlTransaction& transaction) -> Status {
        ASSIGN_OR_RETURN(auto result, transaction.Query(sql, params));
        rows = std::move(result);
        return Status::Ok();
      });
  EXPECT_THAT(status, IsOk()) << sql << ": " << status.ToString();
  return rows;
}

RunRecord MakeRun(const std::string& run_id, std::int64_t started_at_ms, std::size_t telemetry_bytes,
                  const std::string& robot_id) {
  RunRecord run;
  run.run_id = run_id;
  run.robot_id = robot_id;
  run.firmware = "fw-1.2";
  run.robot_model = "vac-s";
  run.started_at_ms = started_at_ms;
  run.ended_at_ms = started_at_ms + 60000;
  run.telemetry = Telemetry(run_id, telemetry_bytes);
  return run;
}

}  // namespace storage::testing
