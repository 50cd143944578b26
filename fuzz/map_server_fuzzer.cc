// libFuzzer harness: ROS map_server maps. Inputs starting with 'P' are PGM images (DecodePgm); others are the
// YAML, read from a file beside a small valid PGM (ReadMapServerYaml, which resolves and checks the image).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "slamcore/occupancy_grid.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  if (!bytes.empty() && bytes[0] == 'P') {
    (void)slamcore::DecodePgm(bytes, 0.05, 0.0, 0.0);
    return 0;
  }
  static const std::filesystem::path directory = [] {
    auto dir = std::filesystem::temp_directory_path() / ("map-server-fuzz-" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "map.pgm", std::ios::binary) << "P5\n2 2\n255\n"
                                                     << std::string("\xfe\x00\xcd\xfe", 4);
    return dir;
  }();
  std::ofstream(directory / "map.yaml", std::ios::binary | std::ios::trunc) << bytes;
  (void)slamcore::ReadMapServerYaml((directory / "map.yaml").string());
  return 0;
}
