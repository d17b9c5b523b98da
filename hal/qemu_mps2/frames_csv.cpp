#include "hal/qemu_mps2/frames_csv.h"

#include <cstring>

#include "hal/qemu_mps2/semihosting.h"

namespace bv::qemu {
namespace {

// Splits the next comma-separated field; returns false when there is none left.
bool NextField(const char*& p, const char* end, const char*& f, size_t& n) {
  if (p == nullptr) return false;
  f = p;
  const char* comma = static_cast<const char*>(std::memchr(p, ',', static_cast<size_t>(end - p)));
  if (comma == nullptr) {
    n = static_cast<size_t>(end - p);
    p = nullptr;
  } else {
    n = static_cast<size_t>(comma - p);
    p = comma + 1;
  }
  return true;
}

bool ParseU64(const char* f, size_t n, uint64_t& out) {
  if (n == 0 || n > 19) return false;
  uint64_t v = 0;
  for (size_t i = 0; i < n; ++i) {
    if (f[i] < '0' || f[i] > '9') return false;
    v = v * 10 + static_cast<uint64_t>(f[i] - '0');
  }
  out = v;
  return true;
}

bool CopyField(const char* f, size_t n, char* out) {
  if (n > kMaxCsvField) return false;
  std::memcpy(out, f, n);
  out[n] = '\0';
  return true;
}

}  // namespace

bool IsFramesHeader(const char* line, size_t len) {
  static constexpr char kHeader[] = "index,t_us,omni_file,persp_file";
  return len == sizeof(kHeader) - 1 && std::memcmp(line, kHeader, len) == 0;
}

Status ParseFramesRow(const char* line, size_t len, FramesRow& out) {
  const char* p = line;
  const char* end = line + len;
  const char* f;
  size_t n;
  FramesRow row;
  if (!NextField(p, end, f, n)) return Status(StatusCode::kInvalidArgument, "empty row");
  const bool negative = n > 0 && f[0] == '-';
  uint64_t index = 0;
  if (!ParseU64(f + (negative ? 1 : 0), n - (negative ? 1 : 0), index) || index > INT64_MAX) {
    return Status(StatusCode::kInvalidArgument, "column index is not an integer");
  }
  row.index = negative ? -static_cast<int64_t>(index) : static_cast<int64_t>(index);
  if (!NextField(p, end, f, n) || !ParseU64(f, n, row.t_us)) {
    return Status(StatusCode::kInvalidArgument,
                  "column t_us missing or not a non-negative integer");
  }
  if (!NextField(p, end, f, n) || !CopyField(f, n, row.omni_file)) {
    return Status(StatusCode::kInvalidArgument, "column omni_file missing or too long");
  }
  if (!NextField(p, end, f, n) || !CopyField(f, n, row.persp_file)) {
    return Status(StatusCode::kInvalidArgument, "column persp_file missing or too long");
  }
  if (p != nullptr) return Status(StatusCode::kInvalidArgument, "more than 4 columns");
  out = row;
  return Status();
}

bool LineReader::Fill() {
  if (eof_) return false;
  if (pos_ > 0) {
    std::memmove(buf_, buf_ + pos_, end_ - pos_);
    end_ -= pos_;
    pos_ = 0;
  }
  const int n = SemiRead(fd_, buf_ + end_, sizeof(buf_) - end_);
  if (n <= 0) {
    eof_ = true;
    io_error_ = n < 0;
    return n == 0;
  }
  end_ += static_cast<size_t>(n);
  return true;
}

LineReader::Result LineReader::Next() {
  bool too_long = false;
  len_ = 0;
  for (;;) {
    for (; pos_ < end_; ++pos_) {
      const char c = buf_[pos_];
      if (c == '\n') {
        ++pos_;
        ++line_no_;
        if (len_ > 0 && line_[len_ - 1] == '\r') --len_;
        line_[len_] = '\0';
        return too_long ? Result::kTooLong : Result::kLine;
      }
      if (len_ < kMaxCsvLine) {
        line_[len_++] = c;
      } else {
        too_long = true;
      }
    }
    if (!Fill() && pos_ >= end_) break;
    if (eof_ && pos_ >= end_) break;
  }
  if (io_error_) return Result::kIoError;
  if (len_ == 0 && !too_long) return Result::kEof;
  ++line_no_;  // last line without a terminator
  if (len_ > 0 && line_[len_ - 1] == '\r') --len_;
  line_[len_] = '\0';
  return too_long ? Result::kTooLong : Result::kLine;
}

}  // namespace bv::qemu
