// The one frames.csv parser, shared by the host's sequence reader and the QEMU board's replay.
#include "hal/common/frames_csv.h"

#include <gtest/gtest.h>

namespace bv::hal {
namespace {

TEST(FramesCsv, TheHeaderMayOrderAndExtendTheColumns) {
  FramesColumns c;
  ASSERT_TRUE(ParseFramesHeader("index,t_us,omni_file,persp_file\r", c).ok());
  EXPECT_EQ(c.index, 0);
  EXPECT_EQ(c.persp_file, 3);
  EXPECT_EQ(c.count, 4);
  ASSERT_TRUE(ParseFramesHeader("persp_file,note,t_us,omni_file,index", c).ok());
  EXPECT_EQ(c.persp_file, 0);
  EXPECT_EQ(c.t_us, 2);
  EXPECT_EQ(c.index, 4);
  EXPECT_EQ(c.count, 5);
  const Status st = ParseFramesHeader("index,t_us,omni_file", c);
  EXPECT_EQ(st.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(std::string_view(st.message()).find("persp_file"), std::string_view::npos);
  EXPECT_FALSE(ParseFramesHeader("", c).ok());
}

TEST(FramesCsv, RowsGiveTheirFieldsAsViews) {
  FramesColumns c;
  ASSERT_TRUE(ParseFramesHeader("persp_file,t_us,index,omni_file", c).ok());
  FramesRow r;
  ASSERT_TRUE(ParseFramesRow("p7.yuyv,1234567890123,-7,o7.yuyv\r", c, r).ok());
  EXPECT_EQ(r.index, -7);
  EXPECT_EQ(r.t_us, 1234567890123u);
  EXPECT_EQ(r.omni_file, "o7.yuyv");
  EXPECT_EQ(r.persp_file, "p7.yuyv");
  ASSERT_TRUE(ParseFramesRow(",0,9223372036854775807,", c, r).ok());
  EXPECT_EQ(r.index, INT64_MAX);
  EXPECT_TRUE(r.omni_file.empty());
  EXPECT_TRUE(r.persp_file.empty());
  ASSERT_TRUE(ParseFramesRow(",18446744073709551615,-9223372036854775808,", c, r).ok());
  EXPECT_EQ(r.t_us, UINT64_MAX);
  EXPECT_EQ(r.index, INT64_MIN);
}

TEST(FramesCsv, BadRowsNameTheProblemAndTheField) {
  FramesColumns c;
  ASSERT_TRUE(ParseFramesHeader("index,t_us,omni_file,persp_file", c).ok());
  struct Case {
    const char* row;
    FramesRowProblem problem;
    const char* field;
    int columns;
  } cases[] = {
      {"0,10,,,", FramesRowProblem::kColumnCount, "", 5},
      {"0,10,", FramesRowProblem::kColumnCount, "", 3},
      {"", FramesRowProblem::kColumnCount, "", 1},
      {"x,10,,", FramesRowProblem::kIndex, "x", 4},
      {",10,,", FramesRowProblem::kIndex, "", 4},
      {" 1,10,,", FramesRowProblem::kIndex, " 1", 4},
      {"9223372036854775808,10,,", FramesRowProblem::kIndex, "9223372036854775808", 4},
      {"1,-5,,", FramesRowProblem::kTimestamp, "-5", 4},
      {"1,12x,,", FramesRowProblem::kTimestamp, "12x", 4},
      {"1,18446744073709551616,,", FramesRowProblem::kTimestamp, "18446744073709551616", 4},
      {"1,1.5,,", FramesRowProblem::kTimestamp, "1.5", 4},
  };
  for (const Case& k : cases) {
    FramesRow r;
    const Status st = ParseFramesRow(k.row, c, r);
    EXPECT_EQ(st.code(), StatusCode::kInvalidArgument) << k.row;
    EXPECT_EQ(r.problem, k.problem) << k.row;
    EXPECT_EQ(r.bad_field, k.field) << k.row;
    EXPECT_EQ(r.columns, k.columns) << k.row;
  }
}

}  // namespace
}  // namespace bv::hal
