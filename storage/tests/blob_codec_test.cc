// The stored-bytes format and the credential hash, below the repository.
#include <gtest/gtest.h>

#include "blob_codec.h"
#include "crypto.h"
#include "status_matchers.h"

namespace storage::internal {
namespace {

TEST(BlobCodecTest, RoundTripsBinaryAndEmptyPayloads) {
  for (const std::string& raw : {std::string(), std::string("a\0b", 3), std::string(100000, 'z')}) {
    const EncodedBlob blob = EncodeBlob(raw);
    EXPECT_EQ(blob.raw_size, static_cast<std::int64_t>(raw.size()));
    auto decoded = DecodeBlob(blob.compressed, blob.crc32, blob.raw_size, "test");
    ASSERT_THAT(decoded, IsOk());
    EXPECT_EQ(*decoded, raw);
  }
}

TEST(BlobCodecTest, AnyFlippedByteOrWrongSizeIsDataLoss) {
  const EncodedBlob blob = EncodeBlob("telemetry telemetry telemetry 0123456789");
  for (std::size_t i = 0; i < blob.compressed.size(); ++i) {
    std::string corrupt = blob.compressed;
    corrupt[i] = static_cast<char>(corrupt[i] ^ 0x01);
    EXPECT_EQ(DecodeBlob(corrupt, blob.crc32, blob.raw_size, "x").status().code(), StatusCode::kDataLoss)
        << i;
  }
  EXPECT_EQ(DecodeBlob(blob.compressed, blob.crc32, blob.raw_size + 1, "x").status().code(),
            StatusCode::kDataLoss);
  EXPECT_EQ(DecodeBlob(blob.compressed, blob.crc32, -1, "x").status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(DecodeBlob("", 0, 10, "x").status().code(), StatusCode::kDataLoss);
}

TEST(CryptoTest, Sha256MatchesTheStandardVector) {
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(CryptoTest, SecretHashesAreSaltedAndVerify) {
  const PasswordHash a = HashSecret("pw");
  const PasswordHash b = HashSecret("pw");
  EXPECT_NE(a.salt, b.salt);
  EXPECT_NE(a.hash, b.hash);
  EXPECT_TRUE(VerifySecret("pw", a));
  EXPECT_FALSE(VerifySecret("pW", a));
  PasswordHash damaged = a;
  damaged.hash.pop_back();
  EXPECT_FALSE(VerifySecret("pw", damaged));
}

}  // namespace
}  // namespace storage::internal
