#pragma once
// Opens the serial link to the coprocessor for the commands that talk to it (listen, capture,
// sync):
// a serial device or pty (raw, at `baud`), tcp:HOST:PORT (QEMU's socket chardev), or a file /
// '-' holding a recorded stream (read only).
#include <sys/types.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>

namespace bv::cli {

/// A rate the serial port can be set to.
bool BaudSupported(long baud);

/// The descriptor, or -1 with `err` set. `writable`: requests can be sent (not a recording).
/// `read_only`: never opened for writing (a listener; a FIFO then still sees its end).
int OpenLink(const std::string& src, long baud, bool& writable, std::string& err,
             bool read_only = false);

/// One read for a loop that runs until the source ends, `seconds` have passed since `start`
/// (0: no limit) or a signal arrived: the bytes read (> 0), 0 to read again (EINTR, a quiet
/// tty), or -1 to stop. A read error is printed as "CMD: read failed: ...".
ssize_t ReadLinkChunk(int fd, uint8_t* buf, size_t size,
                      std::chrono::steady_clock::time_point start, double seconds, const char* cmd);

}  // namespace bv::cli
