// How byte payloads are stored: zlib-compressed (compress2), with the CRC32 of the stored (compressed)
// bytes and the uncompressed size beside them. Decoding checks the CRC before inflating and the size
// after, so a flipped byte is DATA_LOSS, never data.
#pragma once

#include <cstdint>
#include <string>

#include "storage/status.h"

namespace storage::internal {

struct EncodedBlob {
  std::string compressed;
  std::int64_t crc32 = 0;
  std::int64_t raw_size = 0;
};

EncodedBlob EncodeBlob(const std::string& raw);

/// `what` names the payload in the error message, e.g. "telemetry of run r1".
Result<std::string> DecodeBlob(const std::string& compressed, std::int64_t crc32, std::int64_t raw_size,
                               const std::string& what);

}  // namespace storage::internal
