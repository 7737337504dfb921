// The drone estimate at an image's stamp: interpolated between two estimates, moved on with the velocity past
// them, and the heading turn the estimator has learnt.
#include <cmath>

#include <gtest/gtest.h>

#include "uav_vision/estimate_history.h"

namespace uav_vision::test {
namespace {

Eigen::Quaterniond yawOf(double yaw) { return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())); }

// The drone flies along x at 5 m/s; the estimate comes at 50 Hz and its heading turn grows by 0.01 rad each time.
EstimateHistory flyingAt5mps(double until, double max_extrapolation = 0.1) {
  EstimateHistory history(max_extrapolation);
  int i = 0;
  for (double t = 0.0; t <= until + 1e-9; t += 0.02, ++i)
    history.add({t, Eigen::Vector3d(5.0 * t, 1.0, 4.0), Eigen::Vector3d(5.0, 0.0, 0.0), 0.01 * i});
  return history;
}

TEST(EstimateHistory, BetweenTwoEstimatesThePositionIsInterpolated) {
  const auto estimate = flyingAt5mps(1.0).at(0.505);
  ASSERT_TRUE(estimate);
  EXPECT_NEAR(estimate->position.x(), 2.525, 1e-9);  // the nearer estimate alone would be 2.5: 2.5 cm off
  EXPECT_DOUBLE_EQ(estimate->stamp, 0.505);
  EXPECT_NEAR(estimate->heading_turn, 0.25, 1e-9);  // the nearer one's (t = 0.50)
}

TEST(EstimateHistory, PastTheNewestItMovesOnWithTheVelocityForAWhile) {
  const EstimateHistory history = flyingAt5mps(1.0);
  const auto ahead = history.at(1.08);  // a frame newer than the estimator's latest output
  ASSERT_TRUE(ahead);
  EXPECT_NEAR(ahead->position.x(), 5.4, 1e-9);
  EXPECT_FALSE(history.at(1.2));   // too far past the newest
  EXPECT_FALSE(history.at(-0.2));  // or before the oldest
}

TEST(EstimateHistory, KeepsOneSecondAndRestartsWhenTimeGoesBack) {
  EstimateHistory history = flyingAt5mps(3.0);
  EXPECT_FALSE(history.at(1.5));  // forgotten
  EXPECT_TRUE(history.at(2.5));
  history.add({0.5, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0});  // a new simulation
  EXPECT_FALSE(history.at(2.5));
  ASSERT_TRUE(history.at(0.5));
  EXPECT_EQ(history.at(0.5)->position, Eigen::Vector3d::Zero());
}

TEST(HeadingTurn, IsTheEstimateHeadingMinusTheImuYawWrapped) {
  EXPECT_NEAR(headingTurn(yawOf(0.3), yawOf(0.1)), 0.2, 1e-12);
  EXPECT_NEAR(headingTurn(yawOf(3.1), yawOf(-3.1)), 6.2 - 2.0 * M_PI, 1e-12);  // across +-pi: -0.083 rad, not 6.2
  // Tilt does not enter: the same headings, rolled by 0.2 rad.
  const Eigen::Quaterniond roll(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()));
  EXPECT_NEAR(headingTurn(yawOf(0.3) * roll, yawOf(0.1) * roll), 0.2, 1e-9);
}

}  // namespace
}  // namespace uav_vision::test
