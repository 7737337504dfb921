// Frames rendered by the simulator with their ground truth (a directory of PNGs and a truth.csv written by
// landing_bench.rendered_frames, its columns TRUTH_COLUMNS: src/landing_bench/test/render_fixtures.py for the
// committed fixtures in test/data, `rosrun landing_bench rendered_benchmark` on the fly). Read by the gtests and
// detector_benchmark; not part of the detector.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "uav_vision/camera_geometry.h"

namespace uav_vision {

// One row of truth.csv.
struct RenderedFrame {
  std::string image, band, vehicle, profile;
  double height_landing_platform = 0, camera_height = 0;
  CameraIntrinsics intrinsics;                                   // with the lens distortion
  Eigen::Vector3d pad_in_body, pad_world_aligned, strip_in_body;  // from base_link [m]
  Eigen::Quaterniond attitude, imu_attitude;                     // true, and as the IMU reported it
  double tilt_deg = 0;
  double baro_altitude = 0;                  // the frame's barometric altitude [m] ...
  std::array<double, 4> baro_around{};       // ... and 100 and 50 ms before, 50 and 100 ms after it
  double sonar_range = 0, sonar_range_before = 0, sonar_range_after = 0;  // at the frame, 40 ms before, after
  double sonar_field_of_view = 0;                                // the beam's full width [rad]
  double visible_pad_share = 0;                                  // of the pad's area in the image [0..1]
  int visible_pad_corners = 0, strip_corners_in_view = 0, marker_corners_in_view = 0;
  double pad_shadow_share = 0;         // of the pad's area in view and in shadow [0..1]
  double false_target_share = 0;       // of the red false target's area in the image [0..1]
  double blur_px = 0, exposure_gain = 1, sun_elevation_deg = 90;
  double pixel_noise_std_omitted = 0;  // sensor noise left out of the PNG: add it (addSensorNoise) [fraction of 255]
  // Optional columns (older sets have neither): the pad's face, and the share of the foreign pad (AprilTag pad's
  // world: other tag ids) in the image [0..1]. On the AprilTag pad, strip_in_body is its heading point and the
  // "marker" is the inner tag's square with its white ring.
  std::string pad = "red_square";
  double foreign_pad_share = 0;

  bool wholePadInView() const { return visible_pad_corners == 4; }
  bool padInView() const { return visible_pad_share > 0.0; }
};

// The frame's sonar range and barometric altitude as the node takes them from its readings (ReadingHistory
// at the frame's stamp: the sonar's median of three, the barometer's mean over 0.1 s), half the sonar's beam.
struct FrameSensors {
  double sonar_range, baro_altitude, sonar_half_angle;
};
FrameSensors sensorsAsTheNodeTakesThem(const RenderedFrame& frame);

// Throws std::runtime_error naming the file and the problem.
std::vector<RenderedFrame> loadRenderedFrames(const std::string& dir);
// The frame's image, RGB order, with its omitted sensor noise added from `rng`. Throws std::runtime_error.
cv::Mat loadRenderedImage(const std::string& dir, const RenderedFrame& frame, cv::RNG& rng);
// Normal noise of std-dev `std` (fraction of full scale) on each channel, saturating.
void addSensorNoise(cv::Mat& image, double std, cv::RNG& rng);

}  // namespace uav_vision
