#include "tools/ballvision/safe_write.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

namespace bv::cli {
namespace {

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

const char* KindOf(mode_t m) {
  if (S_ISLNK(m)) return "a symbolic link";
  if (S_ISFIFO(m)) return "a FIFO";
  if (S_ISCHR(m) || S_ISBLK(m)) return "a device";
  if (S_ISDIR(m)) return "a directory";
  if (S_ISSOCK(m)) return "a socket";
  return "not a regular file";
}

std::string DirOf(const std::string& path) {
  const size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

// The rename is only durable once the directory entry is on disk too.
void SyncDir(const std::string& dir) {
  const int d = open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (d < 0) return;
  fsync(d);
  close(d);
}

}  // namespace

bool CheckOutputPath(const std::string& path, std::string& error) {
  struct stat st {};
  if (path.empty()) {
    error = "empty output path";
    return false;
  }
  if (lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return true;
    error = Errno("cannot check " + path);
    return false;
  }
  if (S_ISREG(st.st_mode)) return true;
  error = "refusing to write " + path + ": it is " + KindOf(st.st_mode) +
          " (only regular files are replaced)";
  return false;
}

bool MakeOutputDirectory(const std::string& dir, std::string& error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    error = "cannot create the directory " + dir + ": " + ec.message();
    return false;
  }
  if (!std::filesystem::is_directory(dir, ec)) {
    error = dir + " exists and is not a directory";
    return false;
  }
  return true;
}

SafeOutput::~SafeOutput() { Abandon(); }

void SafeOutput::Abandon() {
  if (fd_ < 0) return;
  close(fd_);
  unlink(tmp_.c_str());
  fd_ = -1;
}

bool SafeOutput::Open(const std::string& path, std::string& error) {
  Abandon();
  if (!CheckOutputPath(path, error)) return false;
  const size_t slash = path.rfind('/');
  const std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  std::string tmpl = DirOf(path) + "/." + base + ".XXXXXX";
  fd_ = mkstemp(tmpl.data());
  if (fd_ < 0) {
    error = Errno("cannot create a temporary file beside " + path);
    return false;
  }
  // mkstemp makes the file 0600; give it what a plain create would (0666 minus the umask).
  const mode_t mask = umask(0);
  umask(mask);
  fchmod(fd_, 0666 & ~mask);
  path_ = path;
  tmp_ = tmpl;
  buf_.clear();
  error_.clear();
  total_ = 0;
  return true;
}

void SafeOutput::Write(std::string_view s) {
  if (fd_ < 0 || !error_.empty()) return;
  buf_.append(s);
  total_ += s.size();
  if (buf_.size() >= (1u << 16)) Flush();
}

bool SafeOutput::Flush() {
  size_t off = 0;
  while (error_.empty() && off < buf_.size()) {
    const ssize_t n = write(fd_, buf_.data() + off, buf_.size() - off);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      error_ = Errno("write to " + path_ + " failed");
      break;
    }
    off += static_cast<size_t>(n);
  }
  buf_.clear();
  return error_.empty();
}

bool SafeOutput::Commit(std::string& error) {
  if (fd_ < 0) {
    error = "internal: commit of a file that is not open";
    return false;
  }
  if (Flush() && fsync(fd_) != 0) error_ = Errno("fsync of " + path_ + " failed");
  if (error_.empty() && close(fd_) != 0) error_ = Errno("close of " + path_ + " failed");
  if (!error_.empty()) {
    error = error_ + "; " + path_ + " left unchanged";
    Abandon();
    return false;
  }
  fd_ = -1;
  // Re-check: something may have appeared at the path while we were writing.
  if (!CheckOutputPath(path_, error) || std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    if (error.empty()) error = Errno("cannot rename " + tmp_ + " to " + path_);
    unlink(tmp_.c_str());
    return false;
  }
  SyncDir(DirOf(path_));
  return true;
}

bool WriteFileAtomic(const std::string& path, std::string_view bytes, std::string& error) {
  SafeOutput out;
  if (!out.Open(path, error)) return false;
  out.Write(bytes);
  return out.Commit(error);
}

bool WriteFileAtomic(const std::string& path, const std::vector<unsigned char>& bytes,
                     std::string& error) {
  return WriteFileAtomic(
      path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()), error);
}

}  // namespace bv::cli
