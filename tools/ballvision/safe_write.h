#pragma once
// Every file the tools write goes through here: a temporary file in the target's directory,
// flushed, fsynced and renamed over the target, so a crash, a full disk or Ctrl-C never leaves
// half a file or clobbers the old one. Only regular files are replaced: a symlink, FIFO,
// device or directory at the target path is refused with a message saying so.
#include <sstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace bv::cli {

/// Writes the whole file. Errors name the path and the reason (errno text).
bool WriteFileAtomic(const std::string& path, std::string_view bytes, std::string& error);
bool WriteFileAtomic(const std::string& path, const std::vector<unsigned char>& bytes,
                     std::string& error);

/// False with a message when `path` exists and is not a regular file (checked with lstat, so a
/// symlink is refused rather than followed).
bool CheckOutputPath(const std::string& path, std::string& error);

/// Creates `dir` and its parents where missing (mkdir -p). False with a message naming it when
/// it cannot be made or exists and is not a directory.
bool MakeOutputDirectory(const std::string& dir, std::string& error);

/// A file written incrementally (CSV rows as they arrive) with the same guarantees. Nothing is
/// visible at `path` until Commit(); destruction without Commit() removes the temporary file.
class SafeOutput {
 public:
  SafeOutput() = default;
  SafeOutput(const SafeOutput&) = delete;
  SafeOutput& operator=(const SafeOutput&) = delete;
  ~SafeOutput();

  bool Open(const std::string& path, std::string& error);
  bool is_open() const { return fd_ >= 0; }
  /// Buffered; a failed write (ENOSPC, EFBIG, EIO) is remembered and reported by Commit().
  void Write(std::string_view s);
  SafeOutput& operator<<(std::string_view s) {
    Write(s);
    return *this;
  }
  SafeOutput& operator<<(char c) {
    Write(std::string_view(&c, 1));
    return *this;
  }
  /// Numbers formatted exactly as std::ostream would (drop-in for an ofstream).
  template <typename T>
  requires std::is_arithmetic_v<T> SafeOutput& operator<<(T v) {
    std::ostringstream o;
    o << v;
    Write(o.str());
    return *this;
  }
  /// Flushes, fsyncs and renames over the target. Returns false with the first error.
  bool Commit(std::string& error);
  size_t bytes_written() const { return total_; }

 private:
  bool Flush();
  void Abandon();

  int fd_ = -1;
  std::string path_, tmp_, buf_, error_;
  size_t total_ = 0;
};

}  // namespace bv::cli
