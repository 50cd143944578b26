// fleetctl: the engineers' and operators' CLI to fleetd.
//
//   fleetctl [--server HOST:PORT] [--token-file F | $FLEET_TOKEN_FILE | $FLEET_TOKEN | --token T] [--tls-ca PEM] COMMAND ...
//     upload PATH...                 .runpb files or directories (robots in parallel, retries)
//     runs [filters] [--limit N]     list runs
//     report RUN [--robot R] [--parameter-set S]   one run's report (--robot when robots share the run id)
//     stats [filters] [--group-by day|firmware|robot_model|parameter_set|robot]
//     compare A B [filters]          two parameter sets, fleet-wide and run by run
//     params put FILE | params list  parameter sets (JSON, see analyzer/parameters.h)
//     reprocess --parameter-set S [filters] [--no-wait]   with a progress bar
//     jobs [--state S] | job ID | cancel ID
//     regions RUN | label RUN REGION LABEL         (both take --robot R too)
//     models train NAME [--classifier K] | models eval NAME [--version V] | models activate NAME V | models list NAME
//     credentials PRINCIPAL | credentials rotate|revoke PRINCIPAL | credentials list   tokens (credential_commands.h)
//     robots delete R --confirm R | audit         erasure and the audit log (admins; admin_commands.h)
//     maps robots|list|show|repair|approve|reject|get|export   map history (map_commands.h)
//     import valetudo|map-server FILE... --robot R       maps made elsewhere into the history (import_commands.h)
// Command groups live in their own files (query_, job_, label_, credential_, admin_, map_, import_commands).
// Every command takes --json: one JSON object on stdout instead of a table. Exit status 0 on success, 1 on
// an RPC error (printed as "fleetctl: CODE: message"), 2 on usage errors.
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>

#include "admin_commands.h"
#include "client.h"
#include "credential_commands.h"
#include "fleet_client/upload_files.h"
#include "fleet_client/uploader.h"
#include "import_commands.h"
#include "job_commands.h"
#include "label_commands.h"
#include "map_commands.h"
#include "query_commands.h"

namespace {

using fleetctl::Client;
using fleetctl::Global;

/// upload PATH... [--threads N]: .runpb files or directories, robots in parallel, retried safely.
int Upload(const Global& global, const std::vector<std::string>& upload_paths, int upload_threads) {
  fleet_client::UploadFilesOptions options;
  options.uploader.server = global.server;
  options.uploader.token = global.token;
  options.uploader.tls_ca = global.tls_ca;
  options.threads = upload_threads;
  const bool interactive = isatty(fileno(stderr)) && !global.json;
  options.progress = [interactive](int done, int total, const fleet_client::UploadOutcome& outcome) {
    if (!outcome.ok)
      std::fprintf(stderr, "%sfleetctl: %s\n", interactive ? "\n" : "", outcome.message.c_str());
    if (interactive) std::fprintf(stderr, "\ruploaded %d/%d runs", done, total);
  };
  std::vector<std::filesystem::path> paths(upload_paths.begin(), upload_paths.end());
  const fleet_client::UploadSummary summary = fleet_client::UploadFiles(paths, options);
  if (interactive) std::fprintf(stderr, "\n");
  if (global.json) {
    std::cout << summary.ToJson() << "\n";
  } else {
    std::cout << summary.Summary() << "\n";
  }
  return summary.failed == 0 && summary.runs > 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"fleetctl: command-line client of fleetd"};
  app.require_subcommand(1);
  Global global;
  std::string token_file;
  if (const char* token = std::getenv("FLEET_TOKEN")) global.token = token;
  if (const char* file = std::getenv("FLEET_TOKEN_FILE")) token_file = file;
  if (const char* server = std::getenv("FLEET_SERVER")) global.server = server;
  if (const char* ca = std::getenv("FLEET_TLS_CA")) global.tls_ca = ca;
  app.add_option("--server", global.server,
                 "fleetd address host:port (default $FLEET_SERVER or 127.0.0.1:50051)");
  app.add_option("--token", global.token,
                 "bearer token (default $FLEET_TOKEN); visible to other users in the process list: prefer "
                 "--token-file or the environment");
  app.add_option("--token-file", token_file,
                 "read the bearer token from this file (default $FLEET_TOKEN_FILE)");
  app.add_option("--tls-ca", global.tls_ca, "PEM CA file: connect with TLS (default $FLEET_TLS_CA)");
  app.add_flag("--json", global.json, "print one JSON object instead of a table");
  app.fallthrough();

  std::vector<std::string> upload_paths;
  int upload_threads = 4;
  auto* upload = app.add_subcommand("upload", "upload .runpb files or directories");
  upload->add_option("paths", upload_paths, "files or directories")->required();
  upload->add_option("--threads", upload_threads, "parallel streams")->check(CLI::Range(1, 256));

  fleetctl::QueryCommands query_commands(app);
  fleetctl::JobCommands job_commands(app);
  fleetctl::LabelCommands label_commands(app);
  fleetctl::CredentialCommands credential_commands(app);
  fleetctl::MapCommands map_commands(app);
  fleetctl::ImportCommands import_commands(app);
  fleetctl::AdminCommands admin_commands(app);

  CLI11_PARSE(app, argc, argv);
  if (!token_file.empty()) {
    std::string error;
    auto token = fleet_client::ReadTokenFile(token_file, &error);
    if (!token) {
      std::cerr << "fleetctl: " << error << "\n";
      return 2;
    }
    global.token = *token;
  }
  Client client(global);
  if (const std::optional<int> status = credential_commands.Run(client, global)) return *status;
  if (const std::optional<int> status = admin_commands.Run(client, global)) return *status;
  if (const std::optional<int> status = map_commands.Run(client, global)) return *status;
  if (const std::optional<int> status = import_commands.Run(client, global)) return *status;

  if (const std::optional<int> status = query_commands.Run(client, global)) return *status;
  if (const std::optional<int> status = job_commands.Run(client, global)) return *status;
  if (const std::optional<int> status = label_commands.Run(client, global)) return *status;
  if (*upload) return Upload(global, upload_paths, upload_threads);
  return 2;
}
