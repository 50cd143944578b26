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
  // The scratch directory goes when the fuzzer exits (libFuzzer ends a timed run with exit()).
  static const struct ScratchDirectory {
    std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("map-server-fuzz-" + std::to_string(getpid()));
    ScratchDirectory() {
      std::filesystem::create_directories(path);
      std::ofstream(path / "map.pgm", std::ios::binary) << "P5\n2 2\n255\n"
                                                        << std::string("\xfe\x00\xcd\xfe", 4);
    }
    ~ScratchDirectory() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  } directory;
  std::ofstream(directory.path / "map.yaml", std::ios::binary | std::ios::trunc) << bytes;
  (void)slamcore::ReadMapServerYaml((directory.path / "map.yaml").string());
  return 0;
}
