#include "hal/host/sequence.h"

#include <png.h>

#include <sys/stat.h>
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <set>
#include <sstream>

namespace bv::host {
namespace {

bool FileExists(const std::string& path) {
  struct stat st;
  return stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

bool EndsWith(const std::string& s, const char* suffix) {
  const size_t n = std::strlen(suffix);
  if (s.size() < n) return false;
  return std::equal(s.end() - static_cast<ptrdiff_t>(n), s.end(), suffix,
                    [](char a, char b) { return std::tolower(a) == std::tolower(b); });
}

std::string RowProblem(const hal::FramesRow& row, const hal::FramesColumns& columns) {
  const std::string field(row.bad_field);
  switch (row.problem) {
    case hal::FramesRowProblem::kColumnCount:
      return "has " + std::to_string(row.columns) + " columns, header has " +
             std::to_string(columns.count);
    case hal::FramesRowProblem::kIndex:
      return "index '" + field + "' is not an integer";
    case hal::FramesRowProblem::kTimestamp:
      return "t_us '" + field + "' is not a non-negative integer";
    case hal::FramesRowProblem::kNone:
      break;
  }
  return "malformed row";
}

uint8_t Clamp8(int v) { return static_cast<uint8_t>(std::clamp(v, 0, 255)); }

bool DecodePng(const std::string& path, const uint8_t* data, size_t size, std::vector<uint8_t>& rgb,
               int& width, int& height, std::string& error) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&image, data, size)) {
    error = path + ": not a readable PNG (" + image.message + ")";
    return false;
  }
  image.format = PNG_FORMAT_RGB;
  if (image.width == 0 || image.height == 0 || image.width > 8192 || image.height > 8192) {
    png_image_free(&image);
    error = path + ": PNG size " + std::to_string(image.width) + "x" +
            std::to_string(image.height) + " outside 1..8192";
    return false;
  }
  rgb.assign(PNG_IMAGE_SIZE(image), 0);
  if (!png_image_finish_read(&image, nullptr, rgb.data(), 0, nullptr)) {
    error = path + ": corrupt PNG (" + image.message + ")";
    png_image_free(&image);
    return false;
  }
  width = static_cast<int>(image.width);
  height = static_cast<int>(image.height);
  return true;
}

}  // namespace

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : line) {
    if (c == ',') {
      out.push_back(cur);
      cur.clear();
    } else if (c != '\r') {
      cur.push_back(c);
    }
  }
  out.push_back(cur);
  return out;
}

void RgbToYuyv(const uint8_t* rgb, int width, int height, uint8_t* yuyv) {
  // BT.601 full range, fixed point (x256); chroma averaged over the horizontal pair.
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u + 1 < width + 1; u += 2) {
      const uint8_t* p0 = rgb + (static_cast<size_t>(v) * width + u) * 3;
      const uint8_t* p1 = (u + 1 < width) ? p0 + 3 : p0;
      int ys[2], us = 0, vs = 0;
      for (int k = 0; k < 2; ++k) {
        const uint8_t* p = k ? p1 : p0;
        const int r = p[0], g = p[1], b = p[2];
        ys[k] = (77 * r + 150 * g + 29 * b + 128) >> 8;
        us += -43 * r - 85 * g + 128 * b;
        vs += 128 * r - 107 * g - 21 * b;
      }
      uint8_t* o = yuyv + (static_cast<size_t>(v) * width + u) * 2;
      o[0] = Clamp8(ys[0]);
      o[1] = Clamp8(((us + 256) >> 9) + 128);
      if (u + 1 < width) o[2] = Clamp8(ys[1]);
      if (u + 1 < width) o[3] = Clamp8(((vs + 256) >> 9) + 128);
    }
  }
}

void YuyvToRgb(const uint8_t* yuyv, int width, int height, uint8_t* rgb) {
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const uint8_t* pair = yuyv + (static_cast<size_t>(v) * width + (u & ~1)) * 2;
      const int y = pair[(u & 1) * 2];
      const int cb = pair[1] - 128, cr = pair[3] - 128;
      uint8_t* o = rgb + (static_cast<size_t>(v) * width + u) * 3;
      o[0] = Clamp8(y + ((359 * cr + 128) >> 8));
      o[1] = Clamp8(y - ((88 * cb + 183 * cr + 128) >> 8));
      o[2] = Clamp8(y + ((454 * cb + 128) >> 8));
    }
  }
}

bool LoadYuyv(const std::string& path, std::vector<uint8_t>& out, int& width, int& height,
              std::string& error, int expected_width, int expected_height) {
  if (EndsWith(path, ".yuyv") || EndsWith(path, ".yuv")) {
    std::ifstream f(path, std::ios::binary | std::ios::ate);
    if (!f) {
      error = path + ": cannot open";
      return false;
    }
    const auto size = static_cast<size_t>(f.tellg());
    const size_t want = static_cast<size_t>(expected_width) * expected_height * 2;
    if (size != want) {
      error = path + ": raw YUYV frame has " + std::to_string(size) + " bytes, expected " +
              std::to_string(want) + " (" + std::to_string(expected_width) + "x" +
              std::to_string(expected_height) + "x2)";
      return false;
    }
    out.resize(size);
    f.seekg(0);
    f.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(size));
    if (!f) {
      error = path + ": read failed";
      return false;
    }
    width = expected_width;
    height = expected_height;
    return true;
  }
  if (!EndsWith(path, ".png")) {
    error = path + ": unsupported image type (want .png or .yuyv)";
    return false;
  }
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    error = path + ": cannot open";
    return false;
  }
  const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return DecodePngToYuyv(path, reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), out,
                         width, height, error);
}

bool DecodePngToRgb(const std::string& name, const uint8_t* data, size_t size,
                    std::vector<uint8_t>& rgb, int& width, int& height, std::string& error) {
  return DecodePng(name, data, size, rgb, width, height, error);
}

bool DecodePngToYuyv(const std::string& name, const uint8_t* data, size_t size,
                     std::vector<uint8_t>& out, int& width, int& height, std::string& error) {
  std::vector<uint8_t> rgb;
  if (!DecodePng(name, data, size, rgb, width, height, error)) return false;
  out.resize(static_cast<size_t>(width) * height * 2);
  RgbToYuyv(rgb.data(), width, height, out.data());
  return true;
}

bool EncodePng(const uint8_t* pixels, int width, int height, bool bgr, std::vector<uint8_t>& png,
               std::string& error) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = bgr ? PNG_FORMAT_BGR : PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, pixels, 0, nullptr)) {
    error = std::string("PNG encoding failed (") + image.message + ")";
    return false;
  }
  png.resize(size);
  if (!png_image_write_to_memory(&image, png.data(), &size, 0, pixels, 0, nullptr)) {
    error = std::string("PNG encoding failed (") + image.message + ")";
    png.clear();
    return false;
  }
  png.resize(size);
  return true;
}

bool SaveYuyv(const std::string& path, const uint8_t* yuyv, int width, int height,
              std::string& error) {
  if (EndsWith(path, ".png")) {
    std::vector<uint8_t> rgb(static_cast<size_t>(width) * height * 3);
    YuyvToRgb(yuyv, width, height, rgb.data());
    png_image image;
    std::memset(&image, 0, sizeof image);
    image.version = PNG_IMAGE_VERSION;
    image.width = static_cast<png_uint_32>(width);
    image.height = static_cast<png_uint_32>(height);
    image.format = PNG_FORMAT_RGB;
    if (!png_image_write_to_file(&image, path.c_str(), 0, rgb.data(), 0, nullptr)) {
      error = path + ": PNG write failed (" + image.message + ")";
      return false;
    }
    return true;
  }
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(yuyv), static_cast<std::streamsize>(width) * height * 2);
  if (!f) {
    error = path + ": write failed";
    return false;
  }
  return true;
}

bool LoadSequence(const std::string& dir, Sequence& out, std::string& error) {
  const std::string csv = dir + "/frames.csv";
  std::ifstream f(csv, std::ios::binary);
  if (!f) {
    error = csv + ": cannot open (is '" + dir + "' a captured sequence directory?)";
    return false;
  }
  std::stringstream text;
  text << f.rdbuf();
  return ParseSequenceIndex(text.str(), dir, /*check_files=*/true, out, error);
}

bool ParseSequenceIndex(const std::string& text, const std::string& dir, bool check_files,
                        Sequence& out, std::string& error) {
  const std::string csv = dir + "/frames.csv";
  std::istringstream f(text);
  out = Sequence{};
  out.dir = dir;
  std::string line;
  if (!std::getline(f, line)) {
    error = csv + ": empty file";
    return false;
  }
  hal::FramesColumns columns;
  if (!hal::ParseFramesHeader(line, columns).ok()) {
    error = csv + ":1: header must have columns index,t_us,omni_file,persp_file";
    return false;
  }
  std::set<int64_t> seen;
  int lineno = 1;
  while (std::getline(f, line)) {
    ++lineno;
    if (line.empty() || line == "\r") continue;
    const std::string where = csv + ":" + std::to_string(lineno) + ": ";
    hal::FramesRow row;
    if (!hal::ParseFramesRow(line, columns, row).ok()) {
      error = where + RowProblem(row, columns);
      return false;
    }
    if (!seen.insert(row.index).second) {
      error = where + "duplicate index " + std::to_string(row.index);
      return false;
    }
    if (!out.entries.empty() && row.t_us <= out.entries.back().t_us) {
      error = where + "t_us " + std::to_string(row.t_us) + " is not after the previous row's " +
              std::to_string(out.entries.back().t_us);
      return false;
    }
    SequenceEntry e;
    e.index = row.index;
    e.t_us = row.t_us;
    for (int c = 0; c < 2; ++c) {
      const std::string name(c == 0 ? row.omni_file : row.persp_file);
      if (name.empty()) continue;
      std::string path = name[0] == '/' ? name : dir + "/" + name;
      if (check_files && !FileExists(path)) {
        error = where + "image '" + name + "' not found";
        return false;
      }
      (c == 0 ? e.omni_path : e.persp_path) = path;
    }
    out.entries.push_back(std::move(e));
  }
  if (out.entries.empty()) {
    error = csv + ": no frames";
    return false;
  }
  return true;
}

Status SequenceCamera::DoStart() {
  next_ = 0;
  return seq_.entries.empty() ? Status(StatusCode::kUnavailable, "sequence has no frames")
                              : Status();
}

Status SequenceCamera::DoAcquirePair(hal::FramePair& out) {
  if (next_ >= seq_.entries.size()) return Status(StatusCode::kUnavailable, "end of sequence");
  cur_ = &seq_.entries[next_];
  out = hal::FramePair{};
  out.slot = static_cast<uint32_t>(next_);
  out.exposure_us = cur_->t_us;
  const std::string* paths[2] = {&cur_->omni_path, &cur_->persp_path};
  hal::Frame* frames[2] = {&out.omni, &out.persp};
  for (int c = 0; c < hal::kCameraCount; ++c) {
    if (paths[c]->empty()) continue;
    int w = 0, h = 0;
    std::string err;
    if (!LoadYuyv(*paths[c], buf_[c], w, h, err) || w != 640 || h != 480) {
      if (err.empty()) {
        err = *paths[c] + ": image is " + std::to_string(w) + "x" + std::to_string(h) +
              ", expected 640x480";
      }
      ++load_errors_;
      last_error_ = err;
      continue;
    }
    frames[c]->data = buf_[c].data();
    frames[c]->size_bytes = buf_[c].size();
    frames[c]->exposure_us = cur_->t_us;
    frames[c]->sequence = static_cast<uint32_t>(cur_->index);
    frames[c]->present = true;
  }
  if (!out.omni.present) out.flags |= hal::kPairOmniMissing;
  if (!out.persp.present) out.flags |= hal::kPairPerspMissing;
  if (next_ > 0 && cur_->t_us <= last_t_us_) out.flags |= hal::kPairOutOfOrder;
  last_t_us_ = cur_->t_us;
  ++next_;
  return Status();
}

void SequenceCamera::DoRelease(const hal::FramePair&) {}

}  // namespace bv::host
