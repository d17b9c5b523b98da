#include "tools/ballvision/still_image.h"

#include <dirent.h>
#include <jpeglib.h>
#include <sys/stat.h>

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <fstream>
#include <iterator>

#include "core/common/image.h"
#include "hal/host/sequence.h"

namespace bv::cli {
namespace {

bool EndsWithNoCase(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  for (size_t i = 0; i < suffix.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + i])) !=
        std::tolower(static_cast<unsigned char>(suffix[i]))) {
      return false;
    }
  }
  return true;
}

struct JpegError {
  jpeg_error_mgr mgr;
  jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {};
};

void JpegFail(j_common_ptr info) {
  auto* e = reinterpret_cast<JpegError*>(info->err);
  (*info->err->format_message)(info, e->message);
  std::longjmp(e->jump, 1);
}

// libjpeg goes on after "premature end of data" or "corrupt data" with a warning and grey
// pixels; here any warning fails the decode.
void JpegWarn(j_common_ptr info, int level) {
  if (level < 0) JpegFail(info);
}

std::string TooLarge(const std::string& path, long w, long h, int max_w, int max_h) {
  return path + ": image is " + std::to_string(w) + "x" + std::to_string(h) + ", larger than " +
         (max_w == kMaxFrameWidth && max_h == kMaxFrameHeight
              ? std::string("the largest frame the device takes")
              : std::string("this command takes")) +
         " (" + std::to_string(max_w) + "x" + std::to_string(max_h) + ")";
}

bool DecodeJpeg(const std::string& path, const std::string& bytes, int max_w, int max_h,
                std::vector<uint8_t>& rgb, int& width, int& height, std::string& error) {
  jpeg_decompress_struct info;
  JpegError err;
  info.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = JpegFail;
  err.mgr.emit_message = JpegWarn;
  // volatile: read after a longjmp.
  volatile bool created = false;
  if (setjmp(err.jump)) {
    if (created) jpeg_destroy_decompress(&info);
    error = path + ": corrupt or truncated JPEG (" + err.message + ")";
    return false;
  }
  jpeg_create_decompress(&info);
  created = true;
  jpeg_mem_src(&info, reinterpret_cast<const unsigned char*>(bytes.data()),
               static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&info, TRUE);
  if (info.image_width > static_cast<JDIMENSION>(max_w) ||
      info.image_height > static_cast<JDIMENSION>(max_h)) {
    error = TooLarge(path, info.image_width, info.image_height, max_w, max_h);
    jpeg_destroy_decompress(&info);
    return false;
  }
  info.out_color_space = JCS_RGB;
  jpeg_start_decompress(&info);
  width = static_cast<int>(info.output_width);
  height = static_cast<int>(info.output_height);
  rgb.assign(static_cast<size_t>(width) * height * 3, 0);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = rgb.data() + static_cast<size_t>(info.output_scanline) * width * 3;
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  return true;
}

}  // namespace

bool LoadRgb(const std::string& path, int max_width, int max_height, std::vector<uint8_t>& rgb,
             int& w, int& h, std::string& error) {
  rgb.clear();
  w = h = 0;
  struct stat st;
  if (stat(path.c_str(), &st) != 0) {
    error = path + ": cannot open (no such file)";
    return false;
  }
  if (!S_ISREG(st.st_mode)) {
    error = path + ": not a regular file";
    return false;
  }
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    error = path + ": cannot open";
    return false;
  }
  const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (bytes.empty()) {
    error = path + ": empty file";
    return false;
  }
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const bool jpeg = bytes.size() >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF;
  const bool png = bytes.size() >= 8 && b[0] == 0x89 && b[1] == 'P' && b[2] == 'N' && b[3] == 'G';
  if (jpeg) return DecodeJpeg(path, bytes, max_width, max_height, rgb, w, h, error);
  if (!png) {
    error = path + ": not a JPEG or PNG image";
    return false;
  }
  if (!host::DecodePngToRgb(path, b, bytes.size(), rgb, w, h, error)) return false;
  if (w > max_width || h > max_height) {
    error = TooLarge(path, w, h, max_width, max_height);
    rgb.clear();
    return false;
  }
  return true;
}

bool LoadStill(const std::string& path, Still& out, std::string& error) {
  out = Still{};
  std::vector<uint8_t> rgb;
  int w = 0, h = 0;
  if (!LoadRgb(path, kMaxFrameWidth, kMaxFrameHeight, rgb, w, h, error)) return false;
  out.width = w;
  out.height = h;
  // YUYV pairs pixels: an odd width repeats its last column (nothing of the file is dropped).
  const int pw = (w + 1) & ~1;
  if (pw != w) {
    std::vector<uint8_t> padded(static_cast<size_t>(pw) * h * 3);
    for (int y = 0; y < h; ++y) {
      std::copy_n(rgb.data() + static_cast<size_t>(y) * w * 3, w * 3,
                  padded.data() + static_cast<size_t>(y) * pw * 3);
      std::copy_n(rgb.data() + (static_cast<size_t>(y) * w + w - 1) * 3, 3,
                  padded.data() + (static_cast<size_t>(y) * pw + w) * 3);
    }
    rgb = std::move(padded);
  }
  out.image.width = pw;
  out.image.height = h;
  out.image.yuyv.assign(static_cast<size_t>(pw) * h * 2, 0);
  host::RgbToYuyv(rgb.data(), pw, h, out.image.yuyv.data());
  return true;
}

bool ListStills(const std::string& dir, const std::vector<std::string>& ignore_suffixes,
                std::vector<std::string>& out, std::string& error) {
  out.clear();
  DIR* d = opendir(dir.c_str());
  if (d == nullptr) {
    error = dir + ": cannot read the directory";
    return false;
  }
  std::vector<std::string> names;
  while (const dirent* e = readdir(d)) names.emplace_back(e->d_name);
  closedir(d);
  std::sort(names.begin(), names.end());
  for (const std::string& n : names) {
    if (n == "." || n == "..") continue;
    const std::string path = dir + "/" + n;
    struct stat st;
    if (stat(path.c_str(), &st) != 0 || S_ISDIR(st.st_mode)) continue;
    if (EndsWithNoCase(n, ".jpg") || EndsWithNoCase(n, ".jpeg") || EndsWithNoCase(n, ".png")) {
      out.push_back(path);
      continue;
    }
    const bool ignored = std::any_of(ignore_suffixes.begin(), ignore_suffixes.end(),
                                     [&](const std::string& s) { return EndsWithNoCase(n, s); });
    if (!ignored) {
      error = path + ": not an image (the directory may hold only .jpg, .jpeg and .png files)";
      return false;
    }
  }
  return true;
}

}  // namespace bv::cli
