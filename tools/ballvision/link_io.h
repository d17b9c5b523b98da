#pragma once
// Opens the serial link to the coprocessor for the commands that talk to it (listen, capture,
// sync):
// a serial device or pty (raw, at `baud`), tcp:HOST:PORT (QEMU's socket chardev), or a file /
// '-' holding a recorded stream (read only).
#include <string>

namespace bv::cli {

/// A rate the serial port can be set to.
bool BaudSupported(long baud);

/// The descriptor, or -1 with `err` set. `writable`: requests can be sent (not a recording).
/// `read_only`: never opened for writing (a listener; a FIFO then still sees its end).
int OpenLink(const std::string& src, long baud, bool& writable, std::string& err,
             bool read_only = false);

}  // namespace bv::cli
