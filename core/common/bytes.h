#pragma once
// Bounds-checked little-endian serialisation used by every blob and packet format.
// Writers and readers never go past their span; the first failure sticks and is reported once.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "core/common/status.h"

namespace bv {

class ByteWriter {
 public:
  explicit ByteWriter(std::span<uint8_t> out) : out_(out) {}

  void U8(uint8_t v) { Raw(&v, 1); }
  void U16(uint16_t v) { uint8_t b[2] = {uint8_t(v), uint8_t(v >> 8)}; Raw(b, 2); }
  void U32(uint32_t v) {
    uint8_t b[4] = {uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)};
    Raw(b, 4);
  }
  void U64(uint64_t v) { U32(uint32_t(v)); U32(uint32_t(v >> 32)); }
  void I16(int16_t v) { U16(static_cast<uint16_t>(v)); }
  void I32(int32_t v) { U32(static_cast<uint32_t>(v)); }
  void I64(int64_t v) { U64(static_cast<uint64_t>(v)); }
  void F32(float v) { uint32_t u; std::memcpy(&u, &v, 4); U32(u); }
  void Bytes(std::span<const uint8_t> b) { Raw(b.data(), b.size()); }
  void Raw(const void* p, size_t n) {
    if (!ok_ || n > out_.size() - pos_) { ok_ = false; return; }
    if (n) std::memcpy(out_.data() + pos_, p, n);
    pos_ += n;
  }

  size_t size() const { return pos_; }
  bool ok() const { return ok_; }
  Status status() const {
    return ok_ ? Status() : Status(StatusCode::kResourceExhausted, "output buffer too small");
  }
  std::span<uint8_t> written() const { return out_.first(pos_); }

 private:
  std::span<uint8_t> out_;
  size_t pos_ = 0;
  bool ok_ = true;
};

class ByteReader {
 public:
  explicit ByteReader(std::span<const uint8_t> in) : in_(in) {}

  uint8_t U8() { uint8_t b = 0; Raw(&b, 1); return b; }
  uint16_t U16() { uint8_t b[2] = {}; Raw(b, 2); return uint16_t(b[0] | (b[1] << 8)); }
  uint32_t U32() {
    uint8_t b[4] = {};
    Raw(b, 4);
    return uint32_t(b[0]) | (uint32_t(b[1]) << 8) | (uint32_t(b[2]) << 16) | (uint32_t(b[3]) << 24);
  }
  uint64_t U64() { uint64_t lo = U32(); uint64_t hi = U32(); return lo | (hi << 32); }
  int16_t I16() { return static_cast<int16_t>(U16()); }
  int32_t I32() { return static_cast<int32_t>(U32()); }
  int64_t I64() { return static_cast<int64_t>(U64()); }
  float F32() { uint32_t u = U32(); float f; std::memcpy(&f, &u, 4); return f; }
  void Raw(void* p, size_t n) {
    if (!ok_ || n > in_.size() - pos_) { ok_ = false; if (n) std::memset(p, 0, n); return; }
    if (n) std::memcpy(p, in_.data() + pos_, n);
    pos_ += n;
  }
  std::span<const uint8_t> Take(size_t n) {
    if (!ok_ || n > in_.size() - pos_) { ok_ = false; return {}; }
    auto s = in_.subspan(pos_, n);
    pos_ += n;
    return s;
  }

  size_t position() const { return pos_; }
  size_t remaining() const { return ok_ ? in_.size() - pos_ : 0; }
  bool ok() const { return ok_; }
  Status status() const {
    return ok_ ? Status() : Status(StatusCode::kDataLoss, "input truncated");
  }

 private:
  std::span<const uint8_t> in_;
  size_t pos_ = 0;
  bool ok_ = true;
};

}  // namespace bv
