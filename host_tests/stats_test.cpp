// tools/ballvision/stats.h: the one Median and Percentile of the host tools.
#include "tools/ballvision/stats.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

namespace bv::cli {
namespace {

TEST(Stats, MedianOfAnEvenCountIsTheMeanOfTheMiddleTwo) {
  EXPECT_DOUBLE_EQ(Median({4, 1, 3, 2}), 2.5);
  EXPECT_DOUBLE_EQ(Median({10, -1}), 4.5);
  EXPECT_DOUBLE_EQ(Median({5, 1, 3}), 3);
  EXPECT_DOUBLE_EQ(Median({7}), 7);
  EXPECT_TRUE(std::isnan(Median({})));
}

TEST(Stats, PercentileInterpolatesBetweenRanks) {
  const std::vector<double> v = {0, 10, 20, 30, 40};
  EXPECT_DOUBLE_EQ(Percentile(v, 0), 0);
  EXPECT_DOUBLE_EQ(Percentile(v, 0.9), 36);
  EXPECT_DOUBLE_EQ(Percentile(v, 1), 40);
  EXPECT_DOUBLE_EQ(Percentile({3, 1, 2}, 0.25), 1.5);
  EXPECT_TRUE(std::isnan(Percentile({}, 0.5)));
}

}  // namespace
}  // namespace bv::cli
