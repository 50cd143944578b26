// libFuzzer harness: a ValetudoMap export (JSON, or zlib-deflated JSON) as fleetd's map page takes it —
// the upload's limits (server/src/dashboard_map_routes.cc) — through the import into a snapshot and its
// metadata, and the metadata's own bounds check.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "analyzer/map_metadata.h"
#include "analyzer/valetudo_map.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  analyzer::ValetudoLimits limits;
  limits.max_inflated_bytes = 32u << 20;
  limits.max_json_values = 4'000'000;
  limits.max_total_pixels = 16'000'000;
  limits.max_grid_cells = 16'000'000;
  const auto map =
      analyzer::ParseValetudoMap(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz", limits);
  if (!map.ok()) return 0;
  const analyzer::ImportedMap imported = analyzer::ImportValetudo(*map);
  (void)analyzer::ValidateMetadata(imported.metadata);
  return 0;
}
