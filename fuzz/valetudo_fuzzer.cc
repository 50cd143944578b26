// libFuzzer harness: a ValetudoMap export (JSON, or zlib-deflated JSON) as fleetd's map page takes it —
// the upload's limits (analyzer::ValetudoUploadLimits) — through the import into a snapshot and its
// metadata, and the metadata's own bounds check.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "analyzer/map_metadata.h"
#include "analyzer/valetudo_map.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto map = analyzer::ParseValetudoMap(std::string_view(reinterpret_cast<const char*>(data), size),
                                              "fuzz", analyzer::ValetudoUploadLimits());
  if (!map.ok()) return 0;
  const analyzer::ImportedMap imported = analyzer::ImportValetudo(*map);
  (void)analyzer::ValidateMetadata(imported.metadata);
  return 0;
}
