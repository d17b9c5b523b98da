#pragma once
// Opens the serial link to the coprocessor for the commands that talk to it (capture, sync):
// a serial device or pty (raw, at `baud`), tcp:HOST:PORT (QEMU's socket chardev), or a file /
// '-' holding a recorded stream (read only).
#include <string>

namespace bv::cli {

/// The descriptor, or -1 with `err` set. `writable`: requests can be sent (not a recording).
int OpenLink(const std::string& src, long baud, bool& writable, std::string& err);

}  // namespace bv::cli
