#pragma once
// Lines of a semihosting file through fixed buffers (frames.csv on the device): a line longer
// than kMaxCsvLine is reported and skipped, never truncated.
#include <cstddef>
#include <cstdint>

namespace bv::qemu {

inline constexpr size_t kMaxCsvLine = 256;

/// Reads lines from a semihosting file through a fixed buffer.
class LineReader {
 public:
  enum class Result : uint8_t { kLine, kTooLong, kEof, kIoError };
  /// Starts reading the open semihosting file `handle` from its beginning.
  void Reset(int handle) {
    *this = LineReader();
    fd_ = handle;
  }
  /// Next line without its "\n" / "\r\n" in line()/length(). kTooLong: the line was skipped.
  Result Next();
  const char* line() const { return line_; }
  size_t length() const { return len_; }
  uint32_t line_number() const { return line_no_; }

 private:
  bool Fill();
  int fd_ = -1;
  char buf_[512];
  size_t pos_ = 0, end_ = 0;
  bool eof_ = false;
  bool io_error_ = false;
  char line_[kMaxCsvLine + 1] = {};
  size_t len_ = 0;
  uint32_t line_no_ = 0;
};

}  // namespace bv::qemu
