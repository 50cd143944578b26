// libFuzzer harness: parameter-set JSON (what `fleetctl params put` and PutParameterSet accept) through
// parsing and slamcore's validation.
#include <cstddef>
#include <cstdint>
#include <string>

#include "analyzer/parameters.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string json(reinterpret_cast<const char*>(data), size);
  auto set = analyzer::ParseParameterSetJson(json, "fuzz");
  if (set.ok()) (void)analyzer::FromProto(set->mapper());
  return 0;
}
