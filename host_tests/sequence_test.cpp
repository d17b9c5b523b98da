#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hal/host/sequence.h"

namespace bv::host {
namespace {

std::string TempDir(const char* name) {
  std::string d = std::string(::testing::TempDir()) + "bv_seq_" + name;
  mkdir(d.c_str(), 0755);
  return d;
}

void Write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

void WriteRaw(const std::string& path, size_t bytes) {
  std::vector<char> b(bytes, 0x40);
  std::ofstream(path, std::ios::binary).write(b.data(), static_cast<std::streamsize>(b.size()));
}

TEST(Sequence, LoadsRawAndServesPairsWithMissingCamera) {
  const std::string d = TempDir("ok");
  WriteRaw(d + "/a.yuyv", 640 * 480 * 2);
  WriteRaw(d + "/b.yuyv", 640 * 480 * 2);
  Write(d + "/frames.csv", "index,t_us,omni_file,persp_file\n5,100,a.yuyv,b.yuyv\n9,200,,b.yuyv\n");
  Sequence seq;
  std::string err;
  ASSERT_TRUE(LoadSequence(d, seq, err)) << err;
  ASSERT_EQ(seq.entries.size(), 2u);
  SequenceCamera cam(seq);
  ASSERT_TRUE(cam.Start().ok());
  hal::FramePair p;
  ASSERT_TRUE(cam.AcquirePair(p).ok());
  EXPECT_TRUE(p.omni.present && p.persp.present);
  EXPECT_EQ(p.exposure_us, 100u);
  EXPECT_EQ(p.omni.data[0], 0x40);
  cam.Release(p);
  ASSERT_TRUE(cam.AcquirePair(p).ok());
  EXPECT_EQ(p.flags, static_cast<uint32_t>(hal::kPairOmniMissing));
  EXPECT_TRUE(cam.Finished());
  EXPECT_EQ(cam.AcquirePair(p).code(), StatusCode::kUnavailable);
}

TEST(Sequence, TruncatedRawFrameIsServedMissingAndNamed) {
  const std::string d = TempDir("trunc");
  WriteRaw(d + "/a.yuyv", 1000);
  Write(d + "/frames.csv", "index,t_us,omni_file,persp_file\n0,0,a.yuyv,\n");
  Sequence seq;
  std::string err;
  ASSERT_TRUE(LoadSequence(d, seq, err)) << err;
  SequenceCamera cam(seq);
  hal::FramePair p;
  ASSERT_TRUE(cam.AcquirePair(p).ok());
  EXPECT_FALSE(p.omni.present);
  EXPECT_EQ(cam.load_errors(), 1u);
  EXPECT_NE(cam.last_error().find("1000 bytes, expected 614400"), std::string::npos)
      << cam.last_error();
}

TEST(Sequence, BadIndexFilesAreRejectedWithLineNumbers) {
  struct Case {
    const char* csv;
    const char* expect;
  } cases[] = {
      {"", "empty file"},
      {"index,t_us,omni\n", "header must have"},
      {"index,t_us,omni_file,persp_file\n0,abc,,\n", ":2: t_us 'abc'"},
      {"index,t_us,omni_file,persp_file\n0,10,,\n1,5,,\n", ":3: t_us 5 is not after"},
      {"index,t_us,omni_file,persp_file\n0,10,,\n0,20,,\n", "duplicate index 0"},
      {"index,t_us,omni_file,persp_file\n0,10,nothere.png,\n", "'nothere.png' not found"},
      {"index,t_us,omni_file,persp_file\n0,10,,,\n", "has 5 columns"},
      {"index,t_us,omni_file,persp_file\n", "no frames"},
  };
  int i = 0;
  for (const Case& c : cases) {
    const std::string d = TempDir(("bad" + std::to_string(i++)).c_str());
    Write(d + "/frames.csv", c.csv);
    Sequence seq;
    std::string err;
    EXPECT_FALSE(LoadSequence(d, seq, err)) << c.csv;
    EXPECT_NE(err.find(c.expect), std::string::npos) << "got: " << err;
  }
  Sequence seq;
  std::string err;
  EXPECT_FALSE(LoadSequence("/nonexistent/dir", seq, err));
  EXPECT_NE(err.find("cannot open"), std::string::npos);
}

TEST(Sequence, PngRoundTripAndCorruptPng) {
  const std::string d = TempDir("png");
  std::vector<uint8_t> rgb(64 * 48 * 3), yuyv(64 * 48 * 2), back;
  for (size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = 230, rgb[i + 1] = 120, rgb[i + 2] = 20;  // orange
  }
  RgbToYuyv(rgb.data(), 64, 48, yuyv.data());
  std::string err;
  ASSERT_TRUE(SaveYuyv(d + "/x.png", yuyv.data(), 64, 48, err)) << err;
  int w = 0, h = 0;
  ASSERT_TRUE(LoadYuyv(d + "/x.png", back, w, h, err)) << err;
  EXPECT_EQ(w, 64);
  EXPECT_EQ(h, 48);
  // Same YUYV after a PNG round trip, within rounding of the RGB conversion.
  for (size_t i = 0; i < yuyv.size(); ++i) EXPECT_NEAR(int(back[i]), int(yuyv[i]), 2) << i;
  // BT.601 full range: orange has high V (Cr) and low U (Cb).
  EXPECT_GT(yuyv[3], 170);
  EXPECT_LT(yuyv[1], 90);

  Write(d + "/bad.png", "\x89PNG\r\n\x1a\nthis is not a png");
  EXPECT_FALSE(LoadYuyv(d + "/bad.png", back, w, h, err));
  EXPECT_NE(err.find("bad.png"), std::string::npos);
  EXPECT_FALSE(LoadYuyv(d + "/x.bmp", back, w, h, err));
  EXPECT_NE(err.find("unsupported image type"), std::string::npos);
}

}  // namespace
}  // namespace bv::host
