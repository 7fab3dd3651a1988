// The slope plan (slope_plan.hpp): the slope grid, the uniform plan of explicit
// parameters, and the slice a keypoint is described on.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include <liff/liff.hpp>
#include "slope_plan.hpp"

namespace {

using liff::detail::slopeGrid;
using liff::detail::SlopePlan;

TEST(SlopeGrid, StartsAndEndsExactlyAtTheRangeEvenWhereTheFormulaRoundsPast) {
  // -0.7 + (0.3 - -0.7) * (n - 1) / (n - 1) is 0.30000000000000004 in double.
  for (int n : {2, 3, 7, 11, 33}) {
    const std::vector<double> grid = slopeGrid(-0.7, 0.3, n);
    ASSERT_EQ(int(grid.size()), n);
    EXPECT_EQ(grid.front(), -0.7);
    EXPECT_EQ(grid.back(), 0.3) << n << " slopes";
    for (int i = 1; i < n; ++i) EXPECT_NEAR(grid[i] - grid[i - 1], 1.0 / (n - 1), 1e-12);
  }
}

TEST(SlopeGrid, OneSlopeIsTheMidpointOfTheRange) {
  EXPECT_EQ(slopeGrid(-1, 1, 1), std::vector<double>{0.0});
  EXPECT_EQ(slopeGrid(-0.5, 1.5, 1), std::vector<double>{0.5});
  EXPECT_EQ(slopeGrid(0.3, 0.3, 1), std::vector<double>{0.3});
}

TEST(SlopeGrid, DefaultRangeOfNineSlopesStepsByAQuarter) {
  EXPECT_EQ(slopeGrid(-1, 1, 9),
            (std::vector<double>{-1, -0.75, -0.5, -0.25, 0, 0.25, 0.5, 0.75, 1}));
}

TEST(UniformPlan, DefaultCountIsTheSmallestOddNumberOfAtLeastTheViews) {
  liff::Parameters p;
  p.firstSlope = -1;
  p.lastSlope = 1;
  for (auto [T, S, n] :
       std::vector<std::array<int, 3>>{{9, 9, 9}, {4, 4, 5}, {1, 7, 7}, {3, 8, 9}}) {
    const SlopePlan plan = liff::detail::uniformPlan(p, T, S);
    EXPECT_EQ(plan.size(), n) << T << " x " << S;
    EXPECT_EQ(plan.slopes.front(), -1.0);
    EXPECT_EQ(plan.slopes.back(), 1.0);
    for (int k = 0; k < plan.size(); ++k) EXPECT_TRUE(plan.searched[k]);
  }
  EXPECT_EQ(liff::detail::uniformPlan(p, 1, 1).slopes, std::vector<double>{0.0});
}

TEST(SlopePlan, NearestIsTheClosestSliceOnTheGridAndSkipsGaps) {
  SlopePlan plan;  // grid 0.25 apart, positions 0..2 and 6..7 (a gap of three)
  plan.origin = 0;
  plan.step = 0.25;
  plan.grid = {0, 1, 2, 6, 7};
  for (int g : plan.grid) plan.slopes.push_back(g * 0.25);
  plan.searched = {false, true, false, false, true};
  EXPECT_EQ(plan.nearest(0.3), 1);
  EXPECT_EQ(plan.nearest(-5), 0);
  EXPECT_EQ(plan.nearest(9), 4);
  EXPECT_EQ(plan.nearest(0.8), 2);  // grid position 3: nearest present is 2
  EXPECT_EQ(plan.nearest(1.3), 3);  // position 5: nearest present is 6
  EXPECT_TRUE(plan.adjacent(0));
  EXPECT_FALSE(plan.adjacent(2));
}

}  // namespace

// A hand-set range too narrow for distinct slices (slices closer than class_id's
// resolution; a subnormal width rounds to repeated slopes) is refused naming the range,
// not detected on repeated slices (it ended in std::map::at's exception).
TEST(UniformPlan, SlicesCloserThanTheSlopeResolutionAreRefused) {
  liff::Parameters p;
  p.firstSlope = -5e-324;
  p.lastSlope = 0.0;
  EXPECT_THROW(liff::detail::uniformPlan(p, 3, 3), cv::Exception);
  p.firstSlope = -1e-6;
  EXPECT_THROW(liff::detail::uniformPlan(p, 3, 3), cv::Exception);
  p.numSlopes = 1;  // one slice: any range
  EXPECT_EQ(liff::detail::uniformPlan(p, 3, 3).slopes.size(), 1u);
  p.numSlopes = 0;
  p.firstSlope = -2.0 / liff::kSlopeScale;  // 3 slices exactly the resolution apart
  EXPECT_EQ(liff::detail::uniformPlan(p, 3, 3).slopes.size(), 3u);
}
