#include "fleet_client/channel.h"

#include <grpcpp/grpcpp.h>

#include <fstream>
#include <sstream>

namespace fleet_client {

std::shared_ptr<grpc::Channel> CreateFleetChannel(const std::string& server, const std::string& tls_ca,
                                                  int max_message_bytes) {
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (!tls_ca.empty()) {
    std::ifstream in(tls_ca);
    std::ostringstream pem;
    pem << in.rdbuf();
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = pem.str();
    credentials = grpc::SslCredentials(ssl);
  }
  grpc::ChannelArguments arguments;
  arguments.SetMaxSendMessageSize(max_message_bytes);
  arguments.SetMaxReceiveMessageSize(max_message_bytes);
  // A channel of its own connection, as each robot has: gRPC would otherwise share one connection between
  // all channels to the same server in a process (a load test's 500 robots would be one TCP stream).
  arguments.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  return grpc::CreateCustomChannel(server, credentials, arguments);
}

}  // namespace fleet_client
