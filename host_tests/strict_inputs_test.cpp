// The validation layers of issue 15 (strict_json, cli_args, truth_csv, safe_write) on their
// own; the CLI-level hostile cases are in hostile_cli_test.py.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "host_tests/test_util.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/strict_json.h"
#include "tools/ballvision/truth_csv.h"

namespace bv::cli {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

std::string Slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

TEST(StrictJson, BooleanIsNotANumberStringOrNull) {
  for (const char* text : {R"({"v": 1})", R"({"v": "yes"})", R"({"v": null})"}) {
    const json j = json::parse(text);
    StrictObject r(j, "f.json", "persp");
    bool v = false;
    EXPECT_FALSE(r.Bool("v", v)) << text;
    EXPECT_EQ(r.error().find("f.json: persp.v: got "), 0u) << r.error();
    EXPECT_NE(r.error().find(", expected true or false"), std::string::npos) << r.error();
  }
}

TEST(StrictJson, IntegersAreNotConverted) {
  const json j = json::parse(R"({"a": 18446744073709551616, "b": 1.5, "c": -1, "d": 4294967295,
                                 "e": 1.0})");
  StrictObject r(j, "f.json", "");
  uint32_t v = 7;
  for (const char* k : {"a", "b", "c", "e"}) {
    StrictObject one(j, "f.json", "");
    EXPECT_FALSE(one.U32(k, v)) << k;
    EXPECT_EQ(v, 7u);
  }
  EXPECT_TRUE(r.U32("d", v));
  EXPECT_EQ(v, 4294967295u);
  StrictObject b(j, "f.json", "");
  EXPECT_FALSE(b.U32("b", v));
  EXPECT_EQ(b.error(), "f.json: b: got 1.5 (number), expected an integer in [0, 4294967295]");
}

TEST(StrictJson, FloatRangeMissingAndUnknownKeys) {
  const json j = json::parse(R"({"big": 1e39, "ok": 2.5, "_doc": "x", "typo": 1})");
  StrictObject r(j, "f.json", "omni");
  float f = 0;
  EXPECT_FALSE(r.Float("big", f, -1e40, 1e40));  // beyond float: would become inf
  StrictObject s(j, "f.json", "omni");
  EXPECT_TRUE(s.Float("ok", f, 0, 3));
  EXPECT_EQ(f, 2.5f);
  EXPECT_FALSE(s.Float("missing", f, 0, 1));
  EXPECT_EQ(s.error(), "f.json: omni.missing: missing");
  s.Allow({"big"});
  EXPECT_EQ(s.UnknownKeys(), std::vector<std::string>{"f.json: omni.typo"});
}

TEST(CliArgs, WholeTextTypedAndInRange) {
  std::string e;
  int64_t i = 0;
  double d = 0;
  for (const char* bad : {"", "12x", " 5", "0x10", "99999999999999999999", "-1"}) {
    EXPECT_FALSE(ArgInt("--n", bad, 0, 100, i, e)) << bad;
  }
  EXPECT_EQ(e, "--n: got '-1', expected an integer in [0, 100]");
  for (const char* bad : {"nan", "inf", "1e999", "0.5.1", "", "2"}) {
    EXPECT_FALSE(ArgNumber("--x", bad, 0, 1, d, e)) << bad;
  }
  EXPECT_TRUE(ArgNumber("--x", "0.25", 0, 1, d, e));
  EXPECT_EQ(d, 0.25);
  int64_t a = 0, b = 0;
  EXPECT_TRUE(ArgIntPair("--size", "640x480", 'x', 16, 4096, a, b, e));
  EXPECT_EQ(a * 10000 + b, 6400480);
  EXPECT_FALSE(ArgIntPair("--size", "640", 'x', 16, 4096, a, b, e));
}

TEST(TruthCsvReader, RowsMustMatchTheHeader) {
  const std::string dir = test::TempDir("strict_truth");
  const std::string p = dir + "/truth.csv";
  std::ofstream(p) << "index,t_us,ball_x\n0,0,1\n1,5\n";
  TruthCsv t;
  std::string e;
  EXPECT_FALSE(t.Load(p, {"index"}, e));
  EXPECT_EQ(e, p + ":3: has 2 fields, the header has 3");
  std::ofstream(p) << "index,t_us,ball_x\n0,0,1\n1,5,\n";
  ASSERT_TRUE(t.Load(p, {"index", "t_us"}, e)) << e;
  double v = -1;
  EXPECT_TRUE(t.Number(1, "ball_x", v, true, e));
  EXPECT_EQ(v, -1);  // empty allowed: unchanged
  EXPECT_FALSE(t.Number(1, "ball_x", v, false, e));
  EXPECT_EQ(e, p + ":3: column ball_x: got '', expected a number");
}

TEST(SafeWrite, ReplacesRegularFilesOnlyAndLeavesNoTemporary) {
  const std::string dir = test::TempDir("strict_write");
  const std::string p = dir + "/out.txt";
  std::string e;
  ASSERT_TRUE(WriteFileAtomic(p, std::string("one"), e)) << e;
  ASSERT_TRUE(WriteFileAtomic(p, std::string("two"), e)) << e;
  EXPECT_EQ(Slurp(p), "two");
  fs::create_symlink(p, dir + "/link");
  EXPECT_FALSE(WriteFileAtomic(dir + "/link", std::string("three"), e));
  EXPECT_EQ(e, "refusing to write " + dir +
                   "/link: it is a symbolic link (only regular files "
                   "are replaced)");
  EXPECT_EQ(Slurp(p), "two");
  ASSERT_EQ(mkfifo((dir + "/fifo").c_str(), 0600), 0);
  EXPECT_FALSE(WriteFileAtomic(dir + "/fifo", std::string("x"), e));
  {
    SafeOutput abandoned;  // destroyed without Commit: nothing appears, nothing is left
    ASSERT_TRUE(abandoned.Open(dir + "/never.txt", e));
    abandoned << "rows" << 42 << '\n';
  }
  EXPECT_FALSE(fs::exists(dir + "/never.txt"));
  int entries = 0;
  for ([[maybe_unused]] const auto& d : fs::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 3);  // out.txt, link, fifo
}

TEST(SafeWrite, StreamFormatsNumbersLikeAnOstream) {
  const std::string dir = test::TempDir("strict_stream");
  SafeOutput out;
  std::string e;
  ASSERT_TRUE(out.Open(dir + "/s.csv", e));
  out << "a," << 30.0 << ',' << 1.0 / 3 << ',' << uint32_t{7} << '\n';
  ASSERT_TRUE(out.Commit(e)) << e;
  std::ostringstream want;
  want << "a," << 30.0 << ',' << 1.0 / 3 << ',' << uint32_t{7} << '\n';
  EXPECT_EQ(Slurp(dir + "/s.csv"), want.str());
}

}  // namespace
}  // namespace bv::cli
