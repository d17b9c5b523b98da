#include <array>
#include <cstring>

#include <gtest/gtest.h>

#include "core/common/blob.h"
#include "core/common/crc32.h"

namespace bv {
namespace {

TEST(Crc32, CheckValue) {
  const char* s = "123456789";
  EXPECT_EQ(Crc32({reinterpret_cast<const uint8_t*>(s), 9}), 0xCBF43926u);
  const uint32_t part = Crc32Update(0, {reinterpret_cast<const uint8_t*>(s), 4});
  EXPECT_EQ(Crc32Update(part, {reinterpret_cast<const uint8_t*>(s) + 4, 5}), 0xCBF43926u);
}

TEST(Blob, RoundTripAndEveryCorruptionRejected) {
  const std::array<uint8_t, 5> payload = {1, 2, 3, 4, 5};
  std::array<uint8_t, 64> buf{};
  auto n = WriteBlob(BlobKind::kColorLut, 1, payload, buf);
  ASSERT_TRUE(n.ok());
  ASSERT_EQ(*n, kBlobHeaderBytes + payload.size());
  auto view = ReadBlob({buf.data(), *n}, BlobKind::kColorLut, 1);
  ASSERT_TRUE(view.ok()) << view.status().message();
  EXPECT_EQ(view->payload.size(), payload.size());
  EXPECT_EQ(0, std::memcmp(view->payload.data(), payload.data(), payload.size()));

  // Every truncation is detected.
  for (size_t len = 0; len < *n; ++len) {
    EXPECT_FALSE(ReadBlob({buf.data(), len}, BlobKind::kColorLut, 1).ok()) << len;
  }
  // Every single-bit flip is detected.
  for (size_t i = 0; i < *n; ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      buf[i] ^= uint8_t(1u << bit);
      EXPECT_FALSE(ReadBlob({buf.data(), *n}, BlobKind::kColorLut, 1).ok()) << i << ":" << bit;
      buf[i] ^= uint8_t(1u << bit);
    }
  }
  EXPECT_EQ(ReadBlob({buf.data(), *n}, BlobKind::kCalibration, 1).status().code(),
            StatusCode::kInvalidArgument);
}

TEST(Blob, OutputTooSmallIsReported) {
  const std::array<uint8_t, 8> payload{};
  std::array<uint8_t, 20> buf{};
  EXPECT_EQ(WriteBlob(BlobKind::kCalibration, 1, payload, buf).status().code(),
            StatusCode::kResourceExhausted);
}

}  // namespace
}  // namespace bv
