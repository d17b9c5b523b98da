#include "hal/qemu_mps2/line_reader.h"

#include <cstring>

#include "hal/qemu_mps2/semihosting.h"

namespace bv::qemu {

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
