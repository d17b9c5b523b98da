#include <cstdio>

#include "tools/ballvision/commands.h"

namespace bv::cli {

int CmdSeq(int, char** argv) {
  std::fprintf(stderr, "ballvision %s: not implemented yet\n", argv[0]);
  return 1;
}

}  // namespace bv::cli
