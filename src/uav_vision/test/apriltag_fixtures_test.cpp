// The AprilTag pad on frames the simulator rendered in the realistic profile (test/data/rendered_apriltag, made by
// src/landing_bench/test/render_fixtures.py --set apriltag): from 6 m down to 0.3 m, in the drone's shadow, blurred,
// through the lens, beside the foreign pad (the same tag families, other ids) and the red false target, and frames
// without it. Each frame goes through the localizer as in the node (the drone's own IMU, sonar and barometer); the
// profile's sensor noise, left out of the PNGs, is added here.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "test_support.h"
#include "uav_vision/pad_localizer.h"

namespace uav_vision::test {
namespace {

const CameraMount kMount = CameraMount::bottomCamera(0.035);
constexpr double kFalseDistance = 0.25;  // further than this from the truth, a detection is a false one [m]

std::string apriltagFixturesDir() { return testDataDir() + "/rendered_apriltag"; }

PadLocalizer localizerFor(const RenderedFrame& f) {
  PadLocalizerParams params;
  params.pad = PadKind::kAprilTag;
  params.height.height_landing_platform = f.height_landing_platform;
  return PadLocalizer(params, kMount);
}

// A tag of the pad whole in view: the pad, or (in the last metre, where its cells are large enough) the inner tag.
bool tagInView(const RenderedFrame& f) {
  return f.wholePadInView() || (f.marker_corners_in_view == 4 && f.camera_height < 1.2);
}

class AprilTagFixtures : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    frames_ = loadRenderedFrames(apriltagFixturesDir());
    cv::RNG rng(44);
    for (const auto& f : frames_) images_.push_back(loadRenderedImage(apriltagFixturesDir(), f, rng));
    for (size_t i = 0; i < frames_.size(); ++i) {
      const RenderedFrame& f = frames_[i];
      const FrameSensors sensors = sensorsAsTheNodeTakesThem(f);
      observations_.push_back(localizerFor(f).observe(images_[i], ColorOrder::kRgb, f.intrinsics, f.imu_attitude,
                                                      sensors.sonar_range, sensors.baro_altitude,
                                                      sensors.sonar_half_angle));
    }
  }

  static std::vector<RenderedFrame> frames_;
  static std::vector<cv::Mat> images_;
  static std::vector<PadObservation> observations_;
};
std::vector<RenderedFrame> AprilTagFixtures::frames_;
std::vector<cv::Mat> AprilTagFixtures::images_;
std::vector<PadObservation> AprilTagFixtures::observations_;

TEST_F(AprilTagFixtures, TheSetShowsWhatTheIssueAsksFor) {
  int high = 0, last_half_metre = 0, shadow = 0, foreign = 0, foreign_alone = 0, red = 0, none = 0, car = 0;
  for (const auto& f : frames_) {
    EXPECT_EQ(f.pad, "apriltag") << f.image;
    high += f.wholePadInView() && f.camera_height >= 5.0;
    last_half_metre += f.camera_height <= 0.5 && f.marker_corners_in_view == 4;
    shadow += tagInView(f) && f.pad_shadow_share >= 0.05;
    foreign += f.foreign_pad_share > 0.5 && f.wholePadInView();
    foreign_alone += f.foreign_pad_share > 0.5 && !tagInView(f);
    red += f.false_target_share > 0.5;
    none += !f.padInView();
    car += f.vehicle == "car";
  }
  EXPECT_GE(frames_.size(), 20u);
  EXPECT_GE(high, 2);
  EXPECT_GE(last_half_metre, 3);
  EXPECT_GE(shadow, 3);
  EXPECT_GE(foreign, 1);
  EXPECT_GE(foreign_alone, 2);
  EXPECT_GE(red, 2);
  EXPECT_GE(none, 1);
  EXPECT_GE(car, 2);
}

TEST_F(AprilTagFixtures, EveryTagInViewIsFoundWhereItIsWithItsHeading) {
  for (size_t i = 0; i < frames_.size(); ++i) {
    const RenderedFrame& f = frames_[i];
    const PadObservation& o = observations_[i];
    const double error = o.found ? (o.centre_in_body - f.pad_in_body).head<2>().norm() : NAN;
    std::printf("%-36s h=%.2f shadow=%.2f blur=%.1f foreign=%.2f: %s err=%.4f %s\n", f.image.c_str(), f.camera_height,
                f.pad_shadow_share, f.blur_px, f.foreign_pad_share,
                !o.found ? "none" : o.detection.marker ? "inner tag" : "tags", error, o.reason.c_str());
    if (!tagInView(f)) continue;
    ASSERT_TRUE(o.found) << f.image << ": " << o.reason;
    EXPECT_LE(error, f.camera_height < 1.0 ? 0.01 : 0.03) << f.image;
    // The heading point where the strip's centre was on the red pad: the pad's heading.
    ASSERT_TRUE(o.strip_found) << f.image;
    EXPECT_LE((o.strip_in_body - f.strip_in_body).head<2>().norm(), f.camera_height < 1.0 ? 0.02 : 0.05) << f.image;
  }
}

TEST_F(AprilTagFixtures, NeitherTheForeignPadNorTheRedTargetIsTakenForThePad) {
  int checked = 0;
  for (size_t i = 0; i < frames_.size(); ++i) {
    const RenderedFrame& f = frames_[i];
    const PadObservation& o = observations_[i];
    if (o.found) {
      EXPECT_TRUE(f.padInView()) << f.image << ": a pad reported where there is none";
      EXPECT_LE((o.centre_in_body - f.pad_in_body).head<2>().norm(), kFalseDistance) << f.image;
    }
    if (f.visible_pad_share < 0.5 && f.marker_corners_in_view < 4) {
      // Neither tag can be whole in view: whatever is found is something else (the foreign pad, the red target).
      ++checked;
      EXPECT_FALSE(o.found) << f.image << ": found with no tag of the pad whole in view";
    }
  }
  EXPECT_GE(checked, 4);
}

}  // namespace
}  // namespace uav_vision::test
