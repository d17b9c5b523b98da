#include "hal/qemu_mps2/semihosting.h"

#include <cstring>

namespace bv::qemu {
namespace {

enum : uint32_t {
  kSysOpen = 0x01,
  kSysClose = 0x02,
  kSysWrite0 = 0x04,
  kSysRead = 0x06,
  kSysFlen = 0x0C,
  kSysGetCmdline = 0x15,
  kSysExitExtended = 0x20,
};
constexpr uint32_t kAdpStoppedApplicationExit = 0x20026;

uint32_t Call(uint32_t op, const void* arg) {
  register uint32_t r0 asm("r0") = op;
  register const void* r1 asm("r1") = arg;
  asm volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}

}  // namespace

int SemiOpenRead(const char* path) {
  const uint32_t block[3] = {reinterpret_cast<uint32_t>(path), 1 /* "rb" */,
                             static_cast<uint32_t>(std::strlen(path))};
  return static_cast<int>(Call(kSysOpen, block));
}

int SemiRead(int handle, void* buf, size_t size) {
  const uint32_t block[3] = {static_cast<uint32_t>(handle), reinterpret_cast<uint32_t>(buf),
                             static_cast<uint32_t>(size)};
  const uint32_t not_read = Call(kSysRead, block);  // bytes NOT read
  if (not_read > size) return -1;
  return static_cast<int>(size - not_read);
}

int SemiClose(int handle) {
  const uint32_t block[1] = {static_cast<uint32_t>(handle)};
  return static_cast<int>(Call(kSysClose, block));
}

long SemiFileLength(int handle) {
  const uint32_t block[1] = {static_cast<uint32_t>(handle)};
  return static_cast<long>(static_cast<int32_t>(Call(kSysFlen, block)));
}

Result<size_t> SemiReadFile(const char* path, std::span<uint8_t> out) {
  const int fd = SemiOpenRead(path);
  if (fd < 0) return Status(StatusCode::kNotFound, "cannot open file");
  const long len = SemiFileLength(fd);
  Status st;
  if (len < 0) {
    st = Status(StatusCode::kDataLoss, "cannot size file");
  } else if (static_cast<size_t>(len) > out.size()) {
    st = Status(StatusCode::kResourceExhausted, "file larger than the buffer");
  } else if (SemiRead(fd, out.data(), static_cast<size_t>(len)) != len) {
    st = Status(StatusCode::kDataLoss, "short read");
  }
  SemiClose(fd);
  if (!st.ok()) return st;
  return static_cast<size_t>(len);
}

bool SemiGetCmdline(char* buf, size_t size) {
  if (size == 0) return false;
  uint32_t block[2] = {reinterpret_cast<uint32_t>(buf), static_cast<uint32_t>(size)};
  if (Call(kSysGetCmdline, block) != 0) {
    buf[0] = '\0';
    return false;
  }
  buf[size - 1] = '\0';
  return true;
}

void SemiWrite0(const char* text) { Call(kSysWrite0, text); }

void SemiWriteHex(const char* name, uint32_t value) {
  char buf[32];
  size_t n = 0;
  for (; name[n] != '\0' && n < 16; ++n) buf[n] = name[n];
  buf[n++] = '=';
  buf[n++] = '0';
  buf[n++] = 'x';
  for (int shift = 28; shift >= 0; shift -= 4)
    buf[n++] = "0123456789ABCDEF"[(value >> shift) & 0xF];
  buf[n++] = '\n';
  buf[n] = '\0';
  SemiWrite0(buf);
}

void SemiWriteDec(const char* name, uint64_t value) {
  char digits[24];
  int nd = 0;
  do {
    digits[nd++] = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value != 0 && nd < 24);
  char buf[64];
  size_t n = 0;
  for (; name[n] != '\0' && n < 32; ++n) buf[n] = name[n];
  buf[n++] = '=';
  while (nd > 0) buf[n++] = digits[--nd];
  buf[n++] = '\n';
  buf[n] = '\0';
  SemiWrite0(buf);
}

void SemiExit(int code) {
  const uint32_t block[2] = {kAdpStoppedApplicationExit, static_cast<uint32_t>(code)};
  Call(kSysExitExtended, block);
  for (;;) {
  }
}

}  // namespace bv::qemu
