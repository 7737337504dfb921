// Camera geometry (pixel <-> pad plane) and the camera height from sonar and barometer.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "test_support.h"
#include "uav_vision/camera_geometry.h"
#include "uav_vision/pad_height_estimator.h"

namespace uav_vision::test {
namespace {

constexpr double kDeg = M_PI / 180.0;
const CameraMount kMount = CameraMount::bottomCamera(0.035);

TEST(CameraIntrinsics, ZeroFocalLengthAndSizeAreProblems) {
  CameraIntrinsics k = simIntrinsics();
  EXPECT_EQ(k.problem(), "");
  k.fx = 0.0;
  EXPECT_NE(k.problem().find("focal length"), std::string::npos);
  k = simIntrinsics();
  k.cy = NAN;
  EXPECT_NE(k.problem(), "");
  k = simIntrinsics();
  k.width = 0;
  EXPECT_NE(k.problem().find("size"), std::string::npos);
}

TEST(PlaneView, LevelCameraImageUpIsForwardAndImageRightIsRight) {
  const PlaneView view(simIntrinsics(), kMount, Eigen::Quaterniond::Identity(), 2.0);
  ASSERT_EQ(view.problem(), "");
  // Principal point: straight below the camera, which is 0.035 m below base_link.
  const auto below = view.pixelToPlane({159.5, 119.5});
  ASSERT_TRUE(below);
  EXPECT_NEAR(below->norm(), 0.0, 1e-12);
  EXPECT_TRUE(view.fromBaseInBody(*below).isApprox(Eigen::Vector3d(0, 0, -2.035), 1e-12));
  // 25.6 px up = 0.1 rad ahead: 0.2 m forward at 2 m.
  const Eigen::Vector3d ahead = view.fromBaseInBody(*view.pixelToPlane({159.5, 119.5 - 25.6}));
  EXPECT_NEAR(ahead.x(), 0.2, 1e-9);
  EXPECT_NEAR(ahead.y(), 0.0, 1e-9);
  // Image right is the drone's right (-y).
  const Eigen::Vector3d right = view.fromBaseInBody(*view.pixelToPlane({159.5 + 25.6, 119.5}));
  EXPECT_NEAR(right.y(), -0.2, 1e-9);
}

TEST(PlaneView, YawTurnsWorldAlignedButNotBodyVectors) {
  const PlaneView view(simIntrinsics(), kMount, attitudeFromRpy(0, 0, 90 * kDeg), 2.0);
  const auto ahead = view.pixelToPlane({159.5, 119.5 - 25.6});
  ASSERT_TRUE(ahead);
  // Facing +y (north): forward is world +y.
  EXPECT_NEAR(ahead->x(), 0.0, 1e-9);
  EXPECT_NEAR(ahead->y(), 0.2, 1e-9);
  EXPECT_NEAR(view.fromBaseInBody(*ahead).x(), 0.2, 1e-9);
}

TEST(PlaneView, TiltedCameraIntersectsTheHorizontalPlane) {
  // Nose down by 10 deg (positive pitch about y): body -z, the optical axis, leans backwards.
  const double pitch = 10 * kDeg, h = 3.0;
  const PlaneView view(simIntrinsics(), kMount, attitudeFromRpy(0, pitch, 0), h);
  const auto centre = view.pixelToPlane({159.5, 119.5});
  ASSERT_TRUE(centre);
  EXPECT_NEAR(centre->x(), -h * std::tan(pitch), 1e-9);
  EXPECT_NEAR(centre->y(), 0.0, 1e-9);
  // Round trip anywhere in the image.
  for (double u : {0.0, 100.0, 319.0})
    for (double v : {0.0, 60.0, 239.0}) {
      const auto p = view.pixelToPlane({u, v});
      ASSERT_TRUE(p);
      const auto back = view.planeToPixel(*p);
      ASSERT_TRUE(back);
      EXPECT_NEAR(back->x, u, 1e-9);
      EXPECT_NEAR(back->y, v, 1e-9);
    }
}

TEST(PlaneView, RaysAboveTheHorizonMissThePlane) {
  // Rolled 80 deg: one image edge looks above the horizon (fov 64 deg).
  const PlaneView view(simIntrinsics(), kMount, attitudeFromRpy(80 * kDeg, 0, 0), 2.0);
  int missed = 0;
  for (double u = 0; u < 320; u += 10) missed += !view.pixelToPlane({u, 119.5}).has_value();
  EXPECT_GT(missed, 0);
}

TEST(PlaneView, BadInputsAreReportedNotUsed) {
  EXPECT_NE(PlaneView(simIntrinsics(), kMount, Eigen::Quaterniond(NAN, 0, 0, 0), 2.0).problem(), "");
  EXPECT_NE(PlaneView(simIntrinsics(), kMount, Eigen::Quaterniond::Identity(), -1.0).problem(), "");
  EXPECT_NE(PlaneView(simIntrinsics(), kMount, Eigen::Quaterniond::Identity(), NAN).problem(), "");
  CameraIntrinsics zero = simIntrinsics();
  zero.fy = 0.0;
  EXPECT_NE(PlaneView(zero, kMount, Eigen::Quaterniond::Identity(), 2.0).problem(), "");
}

// ----- camera height above the pad --------------------------------------------------------------

class HeightEstimation : public ::testing::Test {
 protected:
  PadHeightEstimator estimator_;  // Summit XL pad: 0.497 m
  const Eigen::Quaterniond level_ = Eigen::Quaterniond::Identity();
  // Sonar reading for base_link `base_height` above a surface, level: range = base - 0.065.
  static double sonarOver(double base_height) { return base_height - 0.065; }
};

TEST_F(HeightEstimation, SonarOnThePadWhenTheBarometerSaysSo) {
  // base_link 2.0 m above the ground, over the pad (1.503 m above it).
  const HeightEstimate e = estimator_.estimate(sonarOver(2.0 - 0.497), 2.02, level_);
  ASSERT_TRUE(e.valid);
  EXPECT_EQ(e.source, HeightEstimate::Source::kSonarOnPad);
  EXPECT_NEAR(e.camera_height, 2.0 - 0.497 - 0.035, 1e-9);
}

TEST_F(HeightEstimation, SonarOnTheGroundWhenTheBarometerSaysSo) {
  const HeightEstimate e = estimator_.estimate(sonarOver(2.0), 1.95, level_);
  ASSERT_TRUE(e.valid);
  EXPECT_EQ(e.source, HeightEstimate::Source::kSonarOnGround);
  EXPECT_NEAR(e.camera_height, 2.0 - 0.497 - 0.035, 1e-9);
}

TEST_F(HeightEstimation, AnAmbiguousBarometerLetsTheImageHintDecide) {
  // A surface 2 m below base_link: the ground (base_link 2 m up) or the pad (2.497 m up); the
  // barometer half-way between.
  const double sonar = sonarOver(2.0), baro = 2.0 + 0.25;
  const HeightEstimate unknown = estimator_.estimate(sonar, baro, level_);
  EXPECT_TRUE(unknown.ambiguous);
  const HeightEstimate pad = estimator_.estimate(sonar, baro, level_, Surface::kPad);
  const HeightEstimate ground = estimator_.estimate(sonar, baro, level_, Surface::kGround);
  EXPECT_EQ(pad.source, HeightEstimate::Source::kSonarOnPad);
  EXPECT_NEAR(pad.camera_height, 2.0 - 0.035, 1e-9);
  EXPECT_EQ(ground.source, HeightEstimate::Source::kSonarOnGround);
  EXPECT_NEAR(ground.camera_height, 2.0 - 0.035 - 0.497, 1e-9);
}

TEST_F(HeightEstimation, AHintContradictingTheBarometerIsIgnored) {
  const HeightEstimate e = estimator_.estimate(sonarOver(2.0), 2.0, level_, Surface::kPad);
  EXPECT_EQ(e.source, HeightEstimate::Source::kSonarOnGround);
}

TEST_F(HeightEstimation, TiltShortensTheVerticalDistance) {
  const double tilt = 15 * kDeg, base_above_ground = 3.0;
  const Eigen::Quaterniond tilted = attitudeFromRpy(tilt, 0, 0.3);
  // Sonar along body -z: slant distance from base_link to the ground.
  const double sonar = base_above_ground / std::cos(tilt) - 0.065;
  const HeightEstimate e = estimator_.estimate(sonar, 3.0, tilted);
  ASSERT_TRUE(e.valid);
  EXPECT_EQ(e.source, HeightEstimate::Source::kSonarOnGround);
  EXPECT_NEAR(e.camera_height, base_above_ground - 0.035 * std::cos(tilt) - 0.497, 1e-9);
}

TEST_F(HeightEstimation, AWideBeamEchoesFromStraightBelowWithinItsAngle) {
  const double base_above_ground = 3.0, half_angle = 12 * kDeg;
  for (double tilt_deg : {0.0, 6.0, 12.0, 20.0}) {
    const double tilt = tilt_deg * kDeg;
    const Eigen::Quaterniond tilted = attitudeFromRpy(0, tilt, -1.0);
    // The first echo: straight below while the vertical is inside the cone, else along its nearest edge.
    const double feet_above_ground = base_above_ground - 0.065 * std::cos(tilt);
    const double sonar = feet_above_ground / std::cos(std::max(0.0, tilt - half_angle));
    const HeightEstimate e = estimator_.estimate(sonar, base_above_ground, tilted, Surface::kUnknown, half_angle);
    ASSERT_TRUE(e.valid);
    EXPECT_NEAR(e.camera_height, base_above_ground - 0.035 * std::cos(tilt) - 0.497, 1e-9) << tilt_deg;
    // Taken for a narrow beam, the same range gives a camera height up to cos(tilt) lower.
    if (tilt_deg > 0.0 && tilt_deg <= 12.0) {
      EXPECT_LT(estimator_.estimate(sonar, base_above_ground, tilted).camera_height, e.camera_height - 0.01);
    }
  }
}

TEST_F(HeightEstimation, OutOfRangeOrMissingSonarFallsBackToTheBarometer) {
  for (double sonar : {std::numeric_limits<double>::infinity(), double(NAN), 7.0, -1.0}) {
    const HeightEstimate e = estimator_.estimate(sonar, 8.0, level_);
    ASSERT_TRUE(e.valid) << sonar;
    EXPECT_EQ(e.source, HeightEstimate::Source::kBarometer);
    EXPECT_NEAR(e.camera_height, 8.0 - 0.035 - 0.497, 1e-9);
  }
}

TEST_F(HeightEstimation, SonarOnSomethingElseFallsBackToTheBarometer) {
  // Sonar says 1 m below base_link, the barometer 2.5 m above the ground: neither pad nor ground.
  const HeightEstimate e = estimator_.estimate(sonarOver(1.0), 2.5, level_);
  EXPECT_EQ(e.source, HeightEstimate::Source::kBarometer);
}

TEST_F(HeightEstimation, NothingUsableIsInvalidWithAReason) {
  EXPECT_FALSE(estimator_.estimate(NAN, NAN, level_).valid);
  EXPECT_NE(estimator_.estimate(NAN, NAN, level_).reason, "");
  EXPECT_FALSE(estimator_.estimate(sonarOver(2.0), 2.0, Eigen::Quaterniond(NAN, 0, 0, 0)).valid);
  // Barometer below the pad's top and no sonar: the camera cannot see the pad from above.
  EXPECT_FALSE(estimator_.estimate(NAN, 0.3, level_).valid);
}

TEST_F(HeightEstimation, ParametersAreValidated) {
  EXPECT_EQ(PadHeightEstimator::validate(PadHeightParams()), "");
  PadHeightParams bad;
  bad.height_landing_platform = -1.0;
  EXPECT_NE(PadHeightEstimator::validate(bad).find("height_landing_platform"), std::string::npos);
}

}  // namespace
}  // namespace uav_vision::test
