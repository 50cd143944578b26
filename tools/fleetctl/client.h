// What every fleetctl command shares: global options, the gRPC client with its stubs, error and JSON output.
#pragma once

#include <google/protobuf/util/json_util.h>
#include <CLI/CLI.hpp>
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>
#include <iostream>
#include <memory>
#include <string>
#include <thread>

#include "fleet/status_codes.h"
#include "fleet/v1/service.grpc.pb.h"
#include "fleet_client/channel.h"

namespace fleetctl {

struct Global {
  std::string server = "127.0.0.1:50051";
  std::string token;
  std::string tls_ca;
  bool json = false;
};

/// The run filter options several commands share (--robot, --firmware, --model, --parameter-set, --from, --before).
struct Filter {
  std::string robot, firmware, model, parameter_set;
  double from = 0, before = 0;
  void Add(CLI::App* command) {
    command->add_option("--robot", robot, "robot id");
    command->add_option("--firmware", firmware, "firmware version");
    command->add_option("--model", model, "robot model");
    command->add_option("--parameter-set", parameter_set, "parameter set");
    command->add_option("--from", from, "started at or after (Unix seconds)");
    command->add_option("--before", before, "started before (Unix seconds)");
  }
  fleet::v1::RunFilter Proto() const {
    fleet::v1::RunFilter filter;
    filter.set_robot_id(robot);
    filter.set_firmware(firmware);
    filter.set_robot_model(model);
    filter.set_parameter_set(parameter_set);
    if (from != 0) filter.set_started_from(from);
    if (before != 0) filter.set_started_before(before);
    return filter;
  }
};

class Client {
 public:
  explicit Client(const Global& global) : global_(global) {
    channel_ = fleet_client::CreateFleetChannel(global.server, global.tls_ca, 256 << 20);
    queries = fleet::v1::Queries::NewStub(channel_);
    reprocessing = fleet::v1::Reprocessing::NewStub(channel_);
    labels = fleet::v1::Labels::NewStub(channel_);
    models = fleet::v1::Models::NewStub(channel_);
    admin = fleet::v1::Admin::NewStub(channel_);
    maps = fleet::v1::Maps::NewStub(channel_);
  }
  std::unique_ptr<grpc::ClientContext> Context(int seconds = 60) const {
    auto context = std::make_unique<grpc::ClientContext>();
    if (!global_.token.empty()) context->AddMetadata("authorization", "Bearer " + global_.token);
    context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
    return context;
  }
  /// `rpc(context)` with a fresh context, tried again after a back-off while the server says "retry later"
  /// (RESOURCE_EXHAUSTED: its rate limit; UNAVAILABLE): at most 8 attempts, waits doubling from 0.1 s to 5 s.
  /// For commands that send many requests in a row (label-from-truth).
  template <typename Rpc>
  grpc::Status CallRetrying(Rpc&& rpc) const {
    auto delay = std::chrono::milliseconds(100);
    for (int attempt = 1;; ++attempt) {
      auto context = Context();
      const grpc::Status status = rpc(context.get());
      const bool later = status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED ||
                         status.error_code() == grpc::StatusCode::UNAVAILABLE;
      if (!later || attempt == 8) return status;
      std::this_thread::sleep_for(delay);
      delay = std::min(delay * 2, std::chrono::milliseconds(5000));
    }
  }
  std::unique_ptr<fleet::v1::Queries::Stub> queries;
  std::unique_ptr<fleet::v1::Reprocessing::Stub> reprocessing;
  std::unique_ptr<fleet::v1::Labels::Stub> labels;
  std::unique_ptr<fleet::v1::Models::Stub> models;
  std::unique_ptr<fleet::v1::Admin::Stub> admin;
  std::unique_ptr<fleet::v1::Maps::Stub> maps;

 private:
  const Global& global_;
  std::shared_ptr<grpc::Channel> channel_;
};

/// Prints "fleetctl: [WHAT: ]CODE: message" on one line and returns the exit code 1.
inline int Fail(const grpc::Status& status, const std::string& what = "") {
  std::cerr << "fleetctl: " << (what.empty() ? "" : what + ": ") << fleet::GrpcCodeName(status.error_code())
            << ": " << status.error_message() << "\n";
  return 1;
}

inline void PrintJson(const google::protobuf::Message& message) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  std::cout << json << "\n";
}

}  // namespace fleetctl
