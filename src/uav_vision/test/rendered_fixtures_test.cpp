// Accuracy on images rendered by the simulator (test/data/rendered, made by
// src/landing_bench/test/render_fixtures.py): the pad centre relative to the drone against the ground truth of each
// render.
#include <cmath>
#include <cstdio>
#include <map>

#include <gtest/gtest.h>

#include "test_support.h"
#include "uav_vision/pad_localizer.h"

namespace uav_vision::test {
namespace {

PadLocalizerParams localizerParams(const RenderedFixture& f) {
  PadLocalizerParams params;
  params.height.height_landing_platform = f.height_landing_platform;
  return params;
}

// The horizontal error is what the landing needs; the vertical comes from the height estimate.
double horizontalError(const Eigen::Vector3d& estimate, const Eigen::Vector3d& truth) {
  return (estimate - truth).head<2>().norm();
}

// The pad's centre is determined by what is in view when a corner is, or the whole strip is
// (with one pad edge for its side), or two crossing edges are, or the whole centre marker is: the
// generator records corners, strip and marker.
bool centreObservable(const RenderedFixture& f) {
  return f.visible_pad_corners >= 1 || f.strip_corners_in_view == 4 || f.marker_corners_in_view == 4;
}

struct BandStats {
  int count = 0, found = 0;
  double worst = 0.0, sum = 0.0;
  void add(bool ok, double error) {
    ++count;
    if (!ok) return;
    ++found;
    worst = std::max(worst, error);
    sum += error;
  }
};

std::string bandOf(const RenderedFixture& f) {
  if (f.camera_height < 0.7) return "0: camera < 0.7 m";
  if (f.camera_height < 1.0) return "a: 0.7-1 m";
  if (f.camera_height < 3.0) return "b: 1-3 m";
  if (f.camera_height < 3.95) return "c: 3-3.95 m";
  return "d: 4 m";
}

class RenderedFixtures : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { fixtures_ = loadRenderedFixtures(); }
  static std::vector<RenderedFixture> fixtures_;
};
std::vector<RenderedFixture> RenderedFixtures::fixtures_;

TEST_F(RenderedFixtures, TheSetCoversTheAltitudesTiltsAndPartialViews) {
  ASSERT_GE(fixtures_.size(), 30u);
  int close = 0, low = 0, high = 0, partial = 0, tilted = 0;
  for (const auto& f : fixtures_) {
    close += f.camera_height < 0.7 && f.marker_corners_in_view == 4;
    low += f.camera_height < 1.0;
    high += f.camera_height >= 3.95;
    partial += f.visible_pad_corners < 4;
    tilted += f.tilt_deg > 10.0;
  }
  EXPECT_GE(close, 6);
  EXPECT_GE(low, 10);
  EXPECT_GE(high, 4);
  EXPECT_GE(partial, 10);
  EXPECT_GE(tilted, 8);
}

// With the true camera height and attitude: the image part alone.
TEST_F(RenderedFixtures, CentreFromTheImageWithTrueHeightAndAttitude) {
  std::map<std::string, BandStats> stats;
  for (const auto& f : fixtures_) {
    const PadLocalizer localizer(localizerParams(f), CameraMount::bottomCamera(0.035));
    const cv::Mat image = loadImageRgb(f.image);
    const PadObservation o = localizer.observeAtHeight(image, ColorOrder::kRgb, f.intrinsics, f.attitude, f.camera_height);
    const double error = o.found ? horizontalError(o.centre_in_body, f.pad_in_body) : NAN;
    stats[bandOf(f)].add(o.found, error);
    std::printf("%-28s h=%.2f tilt=%4.1f corners=%d strip=%d found=%d partial=%d err=%.4f m %s\n", f.image.c_str(),
                f.camera_height, f.tilt_deg, f.visible_pad_corners, f.strip_corners_in_view, o.found,
                o.detection.partial, error, o.reason.c_str());
    if (centreObservable(f)) {
      EXPECT_TRUE(o.found) << f.image << ": " << o.reason;
    }
    if (!o.found) continue;
    const double limit = f.camera_height < 1.0 ? 0.02 : 0.05;
    EXPECT_LE(error, limit) << f.image;
  }
  for (const auto& [band, s] : stats)
    std::printf("[true height] %-14s %2d images, %2d found, mean error %.1f cm, worst %.1f cm\n", band.c_str(), s.count,
                s.found, s.found ? 100.0 * s.sum / s.found : 0.0, 100.0 * s.worst);
}

// Camera height tolerance: on the car the sonar hits the cabin roof when it misses the pad, 7 cm
// below the pad's top, and the barometer (0.1 m noise) cannot tell the difference.
double heightTolerance(const RenderedFixture& f) { return f.vehicle == "car" ? 0.08 : 0.04; }

// The whole pipeline from the drone's own sensors: IMU attitude (0.2 deg noise), sonar (1 cm noise,
// pad or ground decided with the barometer, 0.1 m noise) and the image, optionally with pixel noise
// (std-dev as a fraction of full scale, like the simulator's camera/noise).
void checkOwnSensors(const std::vector<RenderedFixture>& fixtures, double pixel_noise) {
  std::map<std::string, BandStats> stats;
  cv::RNG rng(11);
  for (const auto& f : fixtures) {
    const PadLocalizer localizer(localizerParams(f), CameraMount::bottomCamera(0.035));
    cv::Mat image = loadImageRgb(f.image);
    if (pixel_noise > 0.0) {
      cv::Mat noise(image.size(), CV_16SC3);
      rng.fill(noise, cv::RNG::NORMAL, 0.0, 255.0 * pixel_noise);
      cv::add(image, noise, image, cv::noArray(), CV_8UC3);
    }
    const PadObservation o =
        localizer.observe(image, ColorOrder::kRgb, f.intrinsics, f.imu_attitude, f.sonar_range, f.baro_altitude);
    const double error = o.found ? horizontalError(o.centre_in_body, f.pad_in_body) : NAN;
    stats[bandOf(f)].add(o.found, error);
    std::printf("%-28s h=%.2f est=%.3f (%s) found=%d err=%.4f m %s\n", f.image.c_str(), f.camera_height,
                o.height.camera_height, toString(o.height.source), o.found, error, o.reason.c_str());
    if (centreObservable(f)) {
      EXPECT_TRUE(o.found) << f.image << ": " << o.reason;
    }
    if (!o.found) continue;
    EXPECT_NEAR(o.height.camera_height, f.camera_height, heightTolerance(f)) << f.image;
    const double limit = f.camera_height < 1.0 ? 0.02 : 0.05;
    EXPECT_LE(error, limit) << f.image;
    EXPECT_NEAR(o.centre_in_body.z(), f.pad_in_body.z(), heightTolerance(f)) << f.image;
    if (o.strip_found) {
      EXPECT_LE(horizontalError(o.strip_in_body, f.strip_in_body), limit) << f.image;
    }
  }
  for (const auto& [band, s] : stats)
    std::printf("[own sensors, pixel noise %.2f] %-14s %2d images, %2d found, mean error %.1f cm, worst %.1f cm\n",
                pixel_noise, band.c_str(), s.count, s.found, s.found ? 100.0 * s.sum / s.found : 0.0, 100.0 * s.worst);
}

TEST_F(RenderedFixtures, CentreFromTheDronesOwnSensors) { checkOwnSensors(fixtures_, 0.0); }

TEST_F(RenderedFixtures, CentreFromTheDronesOwnSensorsWithPixelNoise) { checkOwnSensors(fixtures_, 0.03); }

}  // namespace
}  // namespace uav_vision::test
