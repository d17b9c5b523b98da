#pragma once
// The blob fuzzers' input convention. Odd first byte: the rest is wrapped as a payload with a
// valid header and CRC, so the fuzzer reaches the checks behind the CRC; even: the rest is the
// blob as received.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/common/blob.h"

namespace bv::fuzz {

// `storage` holds the wrapped blob; the result points into it or into `data`. size > 0.
inline std::span<const uint8_t> BlobFromInput(const uint8_t* data, size_t size, BlobKind kind,
                                              uint16_t version, std::vector<uint8_t>& storage) {
  std::span<const uint8_t> blob(data + 1, size - 1);
  if (data[0] & 1) {
    storage.resize(blob.size() + kBlobHeaderBytes);
    if (!WriteBlob(kind, version, blob, storage).ok()) __builtin_trap();
    blob = storage;
  }
  return blob;
}

}  // namespace bv::fuzz
