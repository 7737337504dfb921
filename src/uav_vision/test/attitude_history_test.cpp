// The attitude at an image's stamp from IMU samples: interpolated between two, turned on by the gyro
// past the last one.
#include <cmath>

#include <gtest/gtest.h>

#include "uav_vision/attitude_history.h"

namespace uav_vision::test {
namespace {

Eigen::Quaterniond rollOf(double angle) { return Eigen::Quaterniond(Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitX())); }

double angleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) { return a.angularDistance(b); }

// The drone rolls at a steady 1 rad/s, sampled at 50 Hz.
AttitudeHistory rollingAt50Hz(double until) {
  AttitudeHistory history(0.05);
  for (double t = 0.0; t <= until + 1e-9; t += 0.02) history.add(t, rollOf(t), Eigen::Vector3d(1.0, 0.0, 0.0));
  return history;
}

TEST(AttitudeHistory, PastTheLastSampleTheGyroTurnsTheAttitudeOn) {
  const AttitudeHistory history = rollingAt50Hz(1.0);
  const auto attitude = history.at(1.0 + 0.0167);  // a frame between this sample and the next
  ASSERT_TRUE(attitude);
  EXPECT_LT(angleBetween(*attitude, rollOf(1.0167)), 1e-9);
  // Held at the last sample instead, it would be 0.0167 rad off: 10 cm at 6 m.
  EXPECT_GT(angleBetween(rollOf(1.0), rollOf(1.0167)), 0.016);
}

TEST(AttitudeHistory, BetweenTwoSamplesItInterpolates) {
  const AttitudeHistory history = rollingAt50Hz(1.0);
  const auto attitude = history.at(0.51);
  ASSERT_TRUE(attitude);
  EXPECT_LT(angleBetween(*attitude, rollOf(0.51)), 1e-9);
}

TEST(AttitudeHistory, TooFarFromEverySampleIsUnknown) {
  const AttitudeHistory history = rollingAt50Hz(1.0);
  EXPECT_FALSE(history.at(1.06));
  EXPECT_FALSE(history.at(-0.06));
  EXPECT_FALSE(AttitudeHistory().at(0.0));
}

TEST(AttitudeHistory, RatesAreInTheBodyFrame) {
  // Yawed by 90 deg, a body roll rate turns the drone about the body x axis (world y), not world x.
  AttitudeHistory history(0.05);
  const Eigen::Quaterniond yawed(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  history.add(0.0, yawed, Eigen::Vector3d(1.0, 0.0, 0.0));
  const auto attitude = history.at(0.04);
  ASSERT_TRUE(attitude);
  EXPECT_LT(angleBetween(*attitude, yawed * rollOf(0.04)), 1e-9);
  EXPECT_GT(angleBetween(*attitude, rollOf(0.04) * yawed), 0.01);
}

TEST(AttitudeHistory, TimeGoingBackRestartsTheHistory) {
  AttitudeHistory history = rollingAt50Hz(1.0);
  history.add(0.2, rollOf(-0.3), Eigen::Vector3d::Zero());
  const auto attitude = history.at(0.2);
  ASSERT_TRUE(attitude);
  EXPECT_LT(angleBetween(*attitude, rollOf(-0.3)), 1e-9);  // not the old timeline's roll of 0.2
  EXPECT_FALSE(history.at(0.9));
}

TEST(AttitudeHistory, NonFiniteRatesHoldTheAttitude) {
  AttitudeHistory history(0.05);
  history.add(0.0, rollOf(0.1), Eigen::Vector3d(NAN, 0.0, 0.0));
  const auto attitude = history.at(0.03);
  ASSERT_TRUE(attitude);
  EXPECT_LT(angleBetween(*attitude, rollOf(0.1)), 1e-9);
}

}  // namespace
}  // namespace uav_vision::test
