#pragma once
// CRC-32 (IEEE 802.3, reflected, poly 0xEDB88320, init/xorout 0xFFFFFFFF): the checksum of
// every blob (calibration, LUT) and every serial packet. crc32("123456789") == 0xCBF43926.
#include <cstddef>
#include <cstdint>
#include <span>

namespace bv {

uint32_t Crc32(std::span<const uint8_t> data);
/// Incremental form: start with crc = 0, feed chunks, the return value is the CRC so far.
uint32_t Crc32Update(uint32_t crc, std::span<const uint8_t> data);

}  // namespace bv
