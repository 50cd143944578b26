// libFuzzer harness: an uploaded run (fleet.v1.RunFile bytes) through everything ingest does before storing:
// unknown-field check, header validation, events and both snapshots through the codec.
#include <cstddef>
#include <cstdint>
#include <string>

#include "analyzer/telemetry_codec.h"
#include "fleet/v1/telemetry.pb.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fleet::v1::RunFile run;
  if (!run.ParseFromArray(data, static_cast<int>(size))) return 0;
  (void)analyzer::FindUnknownField(run, "run");
  (void)analyzer::Validate(run.header());
  (void)analyzer::FromProto(run.events(), "events");
  (void)analyzer::FromProto(run.parent_snapshot(), "parent_snapshot");
  (void)analyzer::FromProto(run.child_snapshot(), "child_snapshot");
  return 0;
}
