// fleetctl's reprocessing commands: parameter sets, reprocessing jobs with a progress bar, the job queue.
//
//   params put FILE | params list
//   reprocess --with S [--robot R] [--firmware F] [--model M] [--only-with-set S] [--from T] [--before T] [--no-wait]
//   jobs [--state S] [--limit N] | job ID | cancel ID
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <string>

#include "client.h"

namespace fleetctl {

class JobCommands {
 public:
  explicit JobCommands(CLI::App& app);
  std::optional<int> Run(Client& client, const Global& global) const;

 private:
  int PutParameterSet(Client& client, const Global& global) const;
  int ListParameterSets(Client& client, const Global& global) const;
  int Reprocess(Client& client, const Global& global) const;
  int ListJobs(Client& client, const Global& global) const;
  int OneJob(Client& client, const Global& global) const;  // job ID or cancel ID

  CLI::App *params_put_ = nullptr, *params_list_ = nullptr, *reprocess_ = nullptr, *jobs_ = nullptr,
           *job_ = nullptr, *cancel_ = nullptr;
  Filter filter_;
  std::string params_file_, reprocess_set_, state_;
  bool no_wait_ = false;
  int limit_ = 100;
  std::int64_t job_id_ = 0;
};

}  // namespace fleetctl
