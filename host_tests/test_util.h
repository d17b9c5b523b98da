#pragma once
// Helpers shared by the host tests (host only: may allocate).
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "core/color_lut/color_lut.h"

namespace bv::test {

/// A per-process scratch directory under the system temp dir, removed at exit.
inline std::string TempDir(const std::string& name) {
  namespace fs = std::filesystem;
  const fs::path d = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  struct Cleanup {
    fs::path p;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  };
  static std::vector<std::unique_ptr<Cleanup>> cleanups;
  cleanups.push_back(std::make_unique<Cleanup>(Cleanup{d}));
  fs::create_directories(d);
  return d.string();
}

/// Calls a CLI command function (bv::cli::Cmd*) with string arguments; argv[0] is the command.
template <typename Fn>
int RunCommand(Fn fn, std::vector<std::string> args) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return fn(static_cast<int>(argv.size()), argv.data());
}

/// Field everywhere, ball for bright grey (Y >= 192, U = V = 128): synthetic shapes drawn in
/// white on a dark image are "ball".
inline const ColorLut& BrightIsBallLut() {
  static const std::unique_ptr<ColorLut> lut = [] {
    auto l = std::make_unique<ColorLut>();
    l->Fill(ColorClass::kField);
    for (int y = 192; y < 256; ++y) {
      l->Set(ColorLut::Index(static_cast<uint8_t>(y), 128, 128), ColorClass::kBall);
    }
    return l;
  }();
  return *lut;
}

}  // namespace bv::test
