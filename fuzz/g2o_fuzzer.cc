// libFuzzer harness: g2o and TORO pose-graph text (slamtool and the data sets' format) through the reader.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "slamcore/graph_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream input(std::string(reinterpret_cast<const char*>(data), size));
  (void)slamcore::ReadPoseGraph(input, "fuzz");
  return 0;
}
