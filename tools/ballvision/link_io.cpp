#include "tools/ballvision/link_io.h"

#include <fcntl.h>
#include <netdb.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>

#include "tools/ballvision/signals.h"

namespace bv::cli {
namespace {

speed_t Baud(long baud) {
  switch (baud) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    case 460800:
      return B460800;
    case 921600:
      return B921600;
    case 1000000:
      return B1000000;
    case 2000000:
      return B2000000;
    default:
      return 0;
  }
}

}  // namespace

bool BaudSupported(long baud) { return Baud(baud) != 0; }

int OpenLink(const std::string& src, long baud, bool& writable, std::string& err, bool read_only) {
  writable = false;
  // A board that exits closes its socket: a write must fail with EPIPE (the command ends and
  // reports what it has), not kill the process with SIGPIPE.
  if (!read_only) std::signal(SIGPIPE, SIG_IGN);
  if (src == "-") return STDIN_FILENO;
  if (src.rfind("tcp:", 0) == 0) {
    const std::string rest = src.substr(4);
    const size_t colon = rest.rfind(':');
    if (colon == std::string::npos) {
      err = "tcp source must be tcp:HOST:PORT";
      return -1;
    }
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* res = nullptr;
    const std::string host = rest.substr(0, colon), port = rest.substr(colon + 1);
    if (getaddrinfo(host.c_str(), port.c_str(), &hints, &res) != 0 || res == nullptr) {
      err = "cannot resolve " + host + ":" + port;
      return -1;
    }
    int fd = -1;
    for (int attempt = 0; attempt < 50 && fd < 0; ++attempt) {  // QEMU may still be starting
      fd = socket(res->ai_family, res->ai_socktype, res->ai_protocol);
      if (fd >= 0 && connect(fd, res->ai_addr, res->ai_addrlen) != 0) {
        close(fd);
        fd = -1;
        usleep(100000);
      }
    }
    freeaddrinfo(res);
    if (fd < 0) err = "cannot connect to " + src + ": " + std::strerror(errno);
    writable = fd >= 0;
    return fd;
  }
  struct stat st {};
  const bool regular = stat(src.c_str(), &st) == 0 && S_ISREG(st.st_mode);
  const int fd = open(src.c_str(), (regular || read_only ? O_RDONLY : O_RDWR) | O_NOCTTY);
  if (fd < 0) {
    err = "cannot open " + src + ": " + std::strerror(errno);
    return -1;
  }
  writable = !regular && !read_only;
  if (isatty(fd)) {
    termios t{};
    if (tcgetattr(fd, &t) == 0) {
      cfmakeraw(&t);
      const speed_t sp = Baud(baud);
      if (sp == 0) {
        err = "unsupported baud rate " + std::to_string(baud);
        close(fd);
        return -1;
      }
      cfsetispeed(&t, sp);
      cfsetospeed(&t, sp);
      t.c_cc[VMIN] = 0;
      t.c_cc[VTIME] = 2;  // reads return after 0.2 s so --seconds is honoured
      tcsetattr(fd, TCSANOW, &t);
    }
  }
  return fd;
}

ssize_t ReadLinkChunk(int fd, uint8_t* buf, size_t size,
                      std::chrono::steady_clock::time_point start, double seconds,
                      const char* cmd) {
  if (InterruptSignal()) return -1;
  if (seconds > 0 &&
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > seconds) {
    return -1;
  }
  const ssize_t n = read(fd, buf, size);
  if (n < 0 && errno == EINTR) return 0;
  if (n < 0) {
    std::fprintf(stderr, "%s: read failed: %s\n", cmd, std::strerror(errno));
    return -1;
  }
  if (n == 0) return isatty(fd) ? 0 : -1;  // end of file / socket closed
  return n;
}

}  // namespace bv::cli
