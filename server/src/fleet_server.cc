#include "server/fleet_server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/support/server_interceptor.h>

#include <fstream>
#include <sstream>

#include "handlers/admin_handler.h"
#include "handlers/ingest_handler.h"
#include "handlers/labels_handler.h"
#include "handlers/maps_handler.h"
#include "handlers/models_handler.h"
#include "handlers/queries_handler.h"
#include "handlers/reprocessing_handler.h"

namespace server {
namespace {

slamcore::Result<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return slamcore::NotFound("cannot read " + path);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

/// gRPC answers a request that does not parse as its message (in proto3, most often a string field holding
/// bytes that are not UTF-8) with INTERNAL and no message before any handler runs: it reads as fleetd's
/// fault, and the client cannot tell what to fix. This turns that one answer into INVALID_ARGUMENT naming the
/// method. No handler of fleetd sends INTERNAL without a message (ToGrpc keeps every status's text).
class UnparsedRequestInterceptor : public grpc::experimental::Interceptor {
 public:
  explicit UnparsedRequestInterceptor(std::string method) : method_(std::move(method)) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(grpc::experimental::InterceptionHookPoints::PRE_SEND_STATUS)) {
      const grpc::Status status = methods->GetSendStatus();
      if (status.error_code() == grpc::StatusCode::INTERNAL && status.error_message().empty()) {
        methods->ModifySendStatus(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                               "request: does not parse as the message " + method_ +
                                                   " takes (a string field holding bytes that are not UTF-8, "
                                                   "or bytes that are no such message)"));
      }
    }
    methods->Proceed();
  }

 private:
  std::string method_;
};

class UnparsedRequestInterceptorFactory : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  grpc::experimental::Interceptor* CreateServerInterceptor(grpc::experimental::ServerRpcInfo* info) override {
    return new UnparsedRequestInterceptor(info->method() ? info->method() : "this method");
  }
};

}  // namespace

class FleetServer::Impl {
 public:
  ServiceContext context;
  std::unique_ptr<RateLimiter> rate_limiter;
  std::unique_ptr<IngestAdmission> admission;
  std::unique_ptr<IngestHandler> ingest;
  std::unique_ptr<QueriesHandler> queries;
  std::unique_ptr<ReprocessingHandler> reprocessing;
  std::unique_ptr<LabelsHandler> labels;
  std::unique_ptr<ModelsHandler> models;
  std::unique_ptr<AdminHandler> admin;
  std::unique_ptr<MapsHandler> maps;
  std::unique_ptr<grpc::Server> server;
  std::string bound;
};

slamcore::Status EnsureDefaultParameterSet(storage::Repository& repository, const std::string& name) {
  auto existing = repository.GetParameterSet(name);
  if (existing.ok()) return slamcore::Status::Ok();
  if (existing.status().code() != slamcore::StatusCode::kNotFound) return existing.status();
  fleet::v1::ParameterSet set;
  set.set_name(name);
  set.set_description("slamcore's defaults");
  set.mutable_mapper();
  bool already = false;
  grpc::Status stored =
      ReprocessingHandler::StoreParameterSet(repository, set, "default_parameter_set", &already);
  if (!stored.ok() && stored.error_code() != grpc::StatusCode::ALREADY_EXISTS) {
    return slamcore::Internal(stored.error_message());
  }
  return slamcore::Status::Ok();
}

slamcore::Result<std::unique_ptr<FleetServer>> FleetServer::Create(const FleetdConfig& config,
                                                                   storage::Repository& repository,
                                                                   Metrics& metrics,
                                                                   Authenticator& authenticator,
                                                                   std::function<void()> job_enqueued) {
  auto impl = std::make_unique<Impl>();
  impl->rate_limiter = std::make_unique<RateLimiter>(config.rate_limit_per_second, config.rate_limit_burst);
  ServiceContext& context = impl->context;
  context.repository = &repository;
  context.authenticator = &authenticator;
  context.rate_limiter = impl->rate_limiter.get();
  impl->admission = std::make_unique<IngestAdmission>(
      IngestAdmissionLimits{config.max_upload_streams, config.max_upload_streams_per_principal,
                            config.max_upload_bytes_in_flight, config.max_upload_bytes_per_principal});
  context.admission = impl->admission.get();
  // Read only while the HTTP side serves /metrics, which main stops before this server is destroyed.
  metrics.AddCollector([admission = impl->admission.get()](Metrics& m) {
    m.SetGauge("fleetd_upload_streams_in_flight", "", static_cast<double>(admission->streams()));
    m.SetGauge("fleetd_upload_bytes_in_flight", "", static_cast<double>(admission->bytes()));
  });
  context.metrics = &metrics;
  context.limits.max_events_per_run = config.max_events_per_run;
  context.limits.max_run_bytes = config.max_run_bytes;
  context.default_parameter_set = config.default_parameter_set;
  context.model_name = config.model_name;
  context.map_policy = MapPolicyOf(config);
  context.job_enqueued = std::move(job_enqueued);
  impl->ingest = std::make_unique<IngestHandler>(context);
  impl->queries = std::make_unique<QueriesHandler>(context);
  impl->reprocessing = std::make_unique<ReprocessingHandler>(context);
  impl->labels = std::make_unique<LabelsHandler>(context);
  impl->models = std::make_unique<ModelsHandler>(context);
  impl->admin = std::make_unique<AdminHandler>(context);
  impl->maps = std::make_unique<MapsHandler>(context);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  std::shared_ptr<grpc::ServerCredentials> credentials = grpc::InsecureServerCredentials();
  if (!config.tls_cert.empty()) {
    auto cert = ReadFile(config.tls_cert);
    if (!cert.ok()) return slamcore::InvalidArgument("tls_cert: " + cert.status().message());
    auto key = ReadFile(config.tls_key);
    if (!key.ok()) return slamcore::InvalidArgument("tls_key: " + key.status().message());
    grpc::SslServerCredentialsOptions ssl;
    ssl.pem_key_cert_pairs.push_back({*key, *cert});
    credentials = grpc::SslServerCredentials(ssl);
  }
  int port = 0;
  builder.AddListeningPort(config.listen, credentials, &port);
  builder.SetMaxReceiveMessageSize(static_cast<int>(config.max_message_bytes));
  builder.SetMaxSendMessageSize(static_cast<int>(std::max<std::int64_t>(config.max_message_bytes, 64 << 20)));
  builder.RegisterService(impl->ingest.get());
  builder.RegisterService(impl->queries.get());
  builder.RegisterService(impl->reprocessing.get());
  builder.RegisterService(impl->labels.get());
  builder.RegisterService(impl->models.get());
  builder.RegisterService(impl->admin.get());
  builder.RegisterService(impl->maps.get());
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(std::make_unique<UnparsedRequestInterceptorFactory>());
  builder.experimental().SetInterceptorCreators(std::move(interceptors));
  impl->server = builder.BuildAndStart();
  if (!impl->server || port == 0)
    return slamcore::Unavailable("listen: cannot bind gRPC to " + config.listen);
  const std::size_t colon = config.listen.rfind(':');
  impl->bound = config.listen.substr(0, colon) + ":" + std::to_string(port);
  impl->server->GetHealthCheckService()->SetServingStatus(true);
  return std::unique_ptr<FleetServer>(new FleetServer(std::move(impl)));
}

FleetServer::FleetServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
FleetServer::~FleetServer() = default;
std::string FleetServer::BoundAddress() const { return impl_->bound; }

void FleetServer::SetServing(bool serving) {
  if (impl_->server) impl_->server->GetHealthCheckService()->SetServingStatus(serving);
}

void FleetServer::Shutdown(std::chrono::system_clock::time_point deadline) {
  if (!impl_->server) return;
  impl_->server->GetHealthCheckService()->SetServingStatus(false);
  impl_->server->Shutdown(deadline);
  impl_->server->Wait();
}

}  // namespace server
