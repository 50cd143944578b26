#include "fleet_client/map_stream.h"

#include <memory>
#include <string>

namespace fleet_client {

grpc::Status ReceiveMap(fleet::v1::Maps::StubInterface& maps, grpc::ClientContext& context,
                        const fleet::v1::GetMapRequest& request, std::size_t max_bytes,
                        fleet::v1::GetMapResponse* answer) {
  answer->Clear();
  std::unique_ptr<grpc::ClientReaderInterface<fleet::v1::GetMapResponse>> reader =
      maps.StreamMap(&context, request);
  fleet::v1::GetMapResponse message;
  std::size_t received = 0;
  while (reader->Read(&message)) {
    received += message.ByteSizeLong();
    if (received > max_bytes) {
      context.TryCancel();
      reader->Finish();  // CANCELLED: ours, not the server's, to report
      answer->Clear();
      return {grpc::StatusCode::RESOURCE_EXHAUSTED, "Maps.StreamMap: robot " + request.robot_id() +
                                                        "'s map passed " + std::to_string(max_bytes) +
                                                        " bytes, the most this client accepts"};
    }
    answer->MergeFrom(message);
  }
  grpc::Status status = reader->Finish();
  if (!status.ok()) answer->Clear();
  return status;
}

}  // namespace fleet_client
