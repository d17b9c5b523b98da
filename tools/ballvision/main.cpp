// ballvision: the host command line. Dispatch only; the commands live in bv_tools_lib.
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "tools/ballvision/commands.h"

namespace {

struct Command {
  const char* name;
  int (*fn)(int, char**);
  const char* help;
};

constexpr Command kCommands[] = {
    {"demo", bv::cli::CmdDemo, "run the full pipeline on a built-in synthetic sequence"},
    {"run", bv::cli::CmdRun, "SEQ --calib FILE [--out states.csv] [--predict-ms N]"},
    {"eval", bv::cli::CmdEval, "SEQ --calib FILE: compare with truth.csv, print error tables"},
    {"eval-field", bv::cli::CmdEvalField, "SEQ --calib FILE: pose, line points, obstacles, ball"},
    {"detect", bv::cli::CmdDetect, "--lut FILE --json OUT IMAGE...: the ball in still images"},
    {"detect-eval", bv::cli::CmdDetectEval,
     "--boxes FILE --images DIR: real-image figures per set and pooled"},
    {"lut", bv::cli::CmdLut, "train | eval | show: colour lookup tables"},
    {"calibrate", bv::cli::CmdCalibrate, "persp | omni: calibrate a camera"},
    {"calib", bv::cli::CmdCalib, "to-blob | to-json | show: convert the calibration file"},
    {"listen", bv::cli::CmdListen, "decode a serial stream (device, pty, file, tcp:HOST:PORT)"},
    {"seq", bv::cli::CmdSeq, "info | to-raw: inspect or convert a captured sequence"},
    {"capture", bv::cli::CmdCapture, "SOURCE --out SEQ: frame pairs from the coprocessor"},
    {"sync", bv::cli::CmdSync, "SOURCE: clock offset and drift of the coprocessor"},
    {"readback", bv::cli::CmdReadback, "SOURCE --out FILE: the colour table or calibration in use"},
};

void Usage(FILE* out) {
  std::fprintf(out, "usage: ballvision COMMAND [ARGS]\n\ncommands:\n");
  for (const Command& c : kCommands) std::fprintf(out, "  %-10s %s\n", c.name, c.help);
  std::fprintf(out, "\n'ballvision COMMAND --help' shows a command's options.\n");
}

// A closed stdout or a full disk behind it is a failure, not a silent success.
int FinishStdout(int rc) {
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::fprintf(stderr, "ballvision: writing to standard output failed: %s\n",
                 std::strerror(errno));
    return rc == 0 ? 1 : rc;
  }
  return rc;
}

}  // namespace

int main(int argc, char** argv) {
  // With fd 1 closed the next open() would get it and printf would write into an output file.
  if (fcntl(STDOUT_FILENO, F_GETFD) < 0) {
    std::fprintf(stderr, "ballvision: standard output is closed\n");
    return 1;
  }
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    Usage(argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  for (const Command& c : kCommands) {
    if (!std::strcmp(argv[1], c.name)) return FinishStdout(c.fn(argc - 1, argv + 1));
  }
  std::fprintf(stderr, "ballvision: unknown command '%s'\n\n", argv[1]);
  Usage(stderr);
  return 2;
}
