#pragma once
// ARM semihosting (QEMU: -semihosting-config enable=on,target=native). Diagnostics go to QEMU's
// stderr through SYS_WRITE0, never to UART0, which carries the binary packet stream.
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/common/status.h"

namespace bv::qemu {

/// Opens a host file for binary reading; returns the handle or -1.
int SemiOpenRead(const char* path);
/// Reads up to `size` bytes; returns the number read (0 at end of file) or -1 on error.
int SemiRead(int handle, void* buf, size_t size);
int SemiClose(int handle);
/// Length of an open file, or -1.
long SemiFileLength(int handle);
/// The `arg=` items of -semihosting-config joined by spaces; false if it does not fit.
bool SemiGetCmdline(char* buf, size_t size);
/// NUL-terminated text to the host's stderr.
void SemiWrite0(const char* text);
/// Writes "name=0xXXXXXXXX\n" to stderr without any formatting library.
void SemiWriteHex(const char* name, uint32_t value);
void SemiWriteDec(const char* name, uint64_t value);
/// Reads a whole host file into `out`. kNotFound (cannot open), kResourceExhausted (larger
/// than `out`), kDataLoss (short read).
Result<size_t> SemiReadFile(const char* path, std::span<uint8_t> out);
/// SYS_EXIT_EXTENDED: QEMU exits with `code`.
[[noreturn]] void SemiExit(int code);

}  // namespace bv::qemu
