#include "tools/ballvision/run_common.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "core/color_lut/color_model.h"
#include "hal/host/sequence.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/safe_write.h"

namespace bv::cli {

void FillBuiltInLut(ColorLut& lut) {
  // The default model is valid by construction (host_tests check it).
  BuildLut(BallColorModel{}, lut).IgnoreError();
}

bool FillBuiltInBallLut(const std::string& name, ColorLut& lut, std::string& error) {
  BallName b = BallName::kRed;
  if (!ParseBallName(name.c_str(), b)) {
    error = "--ball: got '" + name + "', expected red, orange or yellow";
    return false;
  }
  if (!BuildLut(BuiltInBallModel(b), lut).ok()) {
    error = "the built-in model of the " + name + " ball is not valid";
    return false;
  }
  return true;
}

bool LoadClassifierArg(const std::string& arg, BallClassifier& c, std::string& error) {
  c.Clear();
  if (arg == "off") return true;
  if (arg.empty() || arg == "builtin") {
    const Status st = c.Parse(BuiltInBallClassifierBlob());
    if (!st.ok()) error = std::string("built-in ball classifier: ") + st.message();
    return st.ok();
  }
  std::vector<uint8_t> blob;
  if (!ReadFileBytes(arg, blob, error)) return false;
  const Status st = c.Parse(blob);
  if (!st.ok()) {
    error = arg + ": " + st.message();
    return false;
  }
  return true;
}

bool LoadLutOrDefault(const std::string& path, const std::string& calib_path, ColorLut& lut,
                      std::string& used, std::string& error, const std::string& ball) {
  namespace fs = std::filesystem;
  if (!ball.empty()) {
    if (!path.empty() && path != "builtin") {
      error = "--ball chooses a built-in model: it cannot go with --lut " + path;
      return false;
    }
    if (!FillBuiltInBallLut(ball, lut, error)) return false;
    used = "built-in model of the " + ball + " ball (--ball " + ball + ")";
    return true;
  }
  std::string file = path;
  if (file.empty()) {
    if (const char* env = std::getenv("BV_LUT"); env && *env) file = env;
  }
  if (file.empty() && !calib_path.empty()) {
    const fs::path dir = fs::path(calib_path).parent_path() / "luts";
    std::error_code ec;
    if (fs::is_directory(dir, ec)) {
      std::vector<fs::path> found;
      for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::string ext = e.path().extension().string();
        if (ext == ".lut" || ext == ".bin") found.push_back(e.path());
      }
      std::sort(found.begin(), found.end());
      // Prefer a LUT named for the rendered (sim) data.
      for (const auto& f : found) {
        if (f.filename().string().find("sim") != std::string::npos) {
          file = f.string();
          break;
        }
      }
      if (file.empty() && !found.empty()) file = found.front().string();
    }
  }
  if (file == "builtin") {
    FillBuiltInLut(lut);
    used = "built-in colour model (--lut builtin)";
    return true;
  }
  if (file.empty()) {
    FillBuiltInLut(lut);
    used = "built-in colour model (no --lut, no $BV_LUT, no <calib dir>/luts/*.lut)";
    return true;
  }
  std::vector<uint8_t> bytes;
  if (!ReadFileBytes(file, bytes, error)) return false;
  const Status st = ParseLut(bytes, lut);
  if (!st.ok()) {
    error = file + ": " + st.message();
    return false;
  }
  used = file;
  return true;
}

}  // namespace bv::cli
