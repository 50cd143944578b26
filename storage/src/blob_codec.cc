#include "blob_codec.h"

#include <zlib.h>

namespace storage::internal {
namespace {

std::int64_t Crc32Of(const std::string& bytes) {
  // zlib's crc32 takes a uInt length: feed large buffers in pieces.
  uLong crc = crc32(0L, Z_NULL, 0);
  std::size_t offset = 0;
  while (offset < bytes.size()) {
    const std::size_t piece = std::min<std::size_t>(bytes.size() - offset, 1u << 30);
    crc = crc32(crc, reinterpret_cast<const Bytef*>(bytes.data() + offset), static_cast<uInt>(piece));
    offset += piece;
  }
  return static_cast<std::int64_t>(crc);
}

}  // namespace

EncodedBlob EncodeBlob(const std::string& raw) {
  EncodedBlob out;
  out.raw_size = static_cast<std::int64_t>(raw.size());
  uLongf bound = compressBound(static_cast<uLong>(raw.size()));
  out.compressed.resize(bound);
  // Level 1: telemetry uploads are large and arrive on the request path; level 1 gets most of the gain.
  const int rc = compress2(reinterpret_cast<Bytef*>(out.compressed.data()), &bound,
                           reinterpret_cast<const Bytef*>(raw.data()), static_cast<uLong>(raw.size()), 1);
  // compress2 only fails on out-of-memory or a too-small buffer, and compressBound rules out the latter.
  if (rc != Z_OK) throw std::bad_alloc();
  out.compressed.resize(bound);
  out.crc32 = Crc32Of(out.compressed);
  return out;
}

Result<std::string> DecodeBlob(const std::string& compressed, std::int64_t crc32, std::int64_t raw_size,
                               const std::string& what) {
  if (Crc32Of(compressed) != crc32) return DataLoss(what + ": stored bytes fail their CRC32 checksum");
  if (raw_size < 0) return DataLoss(what + ": stored size is negative");
  std::string raw(static_cast<std::size_t>(raw_size), '\0');
  uLongf length = static_cast<uLongf>(raw_size);
  const int rc =
      uncompress(reinterpret_cast<Bytef*>(raw.data()), &length,
                 reinterpret_cast<const Bytef*>(compressed.data()), static_cast<uLong>(compressed.size()));
  if (rc != Z_OK || length != static_cast<uLongf>(raw_size)) {
    return DataLoss(what + ": stored bytes do not inflate to their recorded size");
  }
  return raw;
}

}  // namespace storage::internal
