#pragma once
// Device-side frames.csv parsing (DESIGN.md §4): bounded line length, no allocation, every bad
// row reported with its line number; pure functions so the logic is independent of the board.
#include <cstddef>
#include <cstdint>

#include "core/common/status.h"

namespace bv::qemu {

inline constexpr size_t kMaxCsvLine = 256;   // longer lines are rejected, not truncated
inline constexpr size_t kMaxCsvField = 120;  // per file name

struct FramesRow {
  int64_t index = 0;
  uint64_t t_us = 0;
  char omni_file[kMaxCsvField + 1] = {};  // empty: no omni frame in this row
  char persp_file[kMaxCsvField + 1] = {};
};

/// Parses one data row (no line terminator). Errors (kInvalidArgument) name the bad column.
Status ParseFramesRow(const char* line, size_t len, FramesRow& out);
/// True if `line` is the expected header "index,t_us,omni_file,persp_file".
bool IsFramesHeader(const char* line, size_t len);

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
