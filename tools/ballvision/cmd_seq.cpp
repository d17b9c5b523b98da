// ballvision seq: inspect a captured sequence or convert it to raw .yuyv (what the QEMU board
// reads through semihosting).
#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "hal/host/sequence.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/safe_write.h"

namespace bv::cli {
namespace {

constexpr char kSeqUsage[] =
    "usage: ballvision seq info SEQ\n"
    "       ballvision seq to-raw SEQ OUT_DIR [--first N] [--count M]\n"
    "  to-raw writes OUT_DIR/frames.csv and one 640x480 .yuyv per image\n";

int Info(const std::string& dir) {
  host::Sequence seq;
  std::string err;
  if (!host::LoadSequence(dir, seq, err)) {
    std::fprintf(stderr, "ballvision seq: %s\n", err.c_str());
    return 1;
  }
  size_t omni = 0, persp = 0;
  for (const auto& e : seq.entries) {
    omni += !e.omni_path.empty();
    persp += !e.persp_path.empty();
  }
  const double span_s = (seq.entries.back().t_us - seq.entries.front().t_us) * 1e-6;
  std::printf("%s: %zu frames (%zu omni, %zu persp), %.3f s, %.1f Hz\n", dir.c_str(),
              seq.entries.size(), omni, persp, span_s,
              seq.entries.size() > 1 ? (seq.entries.size() - 1) / span_s : 0.0);
  return 0;
}

int ToRaw(const std::string& dir, const std::string& out_dir, size_t first, size_t count) {
  host::Sequence seq;
  std::string err;
  if (!host::LoadSequence(dir, seq, err)) {
    std::fprintf(stderr, "ballvision seq: %s\n", err.c_str());
    return 1;
  }
  if (first >= seq.entries.size()) {
    std::fprintf(stderr, "ballvision seq: --first %zu is past the last of %zu frames\n", first,
                 seq.entries.size());
    return 1;
  }
  mkdir(out_dir.c_str(), 0755);
  SafeOutput csv;
  if (!csv.Open(out_dir + "/frames.csv", err)) {
    std::fprintf(stderr, "ballvision seq: %s\n", err.c_str());
    return 1;
  }
  csv << "index,t_us,omni_file,persp_file\n";
  const size_t end = std::min(seq.entries.size(), first + count);
  std::vector<uint8_t> buf;
  for (size_t i = first; i < end; ++i) {
    const auto& e = seq.entries[i];
    std::string names[2];
    const std::string* paths[2] = {&e.omni_path, &e.persp_path};
    for (int c = 0; c < 2; ++c) {
      if (paths[c]->empty()) continue;
      int w = 0, h = 0;
      if (!host::LoadYuyv(*paths[c], buf, w, h, err)) {
        std::fprintf(stderr, "ballvision seq: %s\n", err.c_str());
        return 1;
      }
      if (w != 640 || h != 480) {
        std::fprintf(stderr, "ballvision seq: %s is %dx%d, expected 640x480\n", paths[c]->c_str(),
                     w, h);
        return 1;
      }
      names[c] = std::string(c ? "persp_" : "omni_") + std::to_string(e.index) + ".yuyv";
      if (!WriteFileAtomic(out_dir + "/" + names[c], buf, err)) {
        std::fprintf(stderr, "ballvision seq: %s\n", err.c_str());
        return 1;
      }
    }
    csv << e.index << ',' << e.t_us << ',' << names[0] << ',' << names[1] << '\n';
  }
  if (!csv.Commit(err)) {
    std::fprintf(stderr, "ballvision seq: %s\n", err.c_str());
    return 1;
  }
  std::printf("wrote %zu frames to %s\n", end - first, out_dir.c_str());
  return 0;
}

}  // namespace

int CmdSeq(int argc, char** argv) {
  const auto info = [](int ac, char** av) {
    std::string dir;
    ArgParser p("ballvision seq info", kSeqUsage);
    p.Positional("SEQ", dir);
    if (const int rc = p.Parse(ac, av); rc >= 0) return rc;
    return Info(dir);
  };
  const auto to_raw = [](int ac, char** av) {
    std::string dir, out;
    size_t first = 0, count = static_cast<size_t>(-1);
    ArgParser p("ballvision seq to-raw", kSeqUsage);
    p.Positional("SEQ", dir)
        .Positional("OUT_DIR", out)
        .Int("--first", 0, INT64_MAX, first)
        .Int("--count", 1, INT64_MAX, count);
    if (const int rc = p.Parse(ac, av); rc >= 0) return rc;
    return ToRaw(dir, out, first, count);
  };
  return RunSubCommand("ballvision seq", kSeqUsage, argc, argv,
                       {{"info", info}, {"to-raw", to_raw}});
}

}  // namespace bv::cli
