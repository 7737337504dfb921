// Pad position relative to the drone from one camera frame and the drone's own sensors (ROS-free):
// detector + height estimator + back-projection onto the pad plane.
#pragma once

#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "uav_vision/camera_geometry.h"
#include "uav_vision/pad_detector.h"
#include "uav_vision/pad_height_estimator.h"

namespace uav_vision {

struct PadLocalizerParams {
  PadDetectorParams detector;
  PadHeightParams height;
  // The sonar's beam (around the optical axis) reaching this far inside the pad outline means its echo comes
  // from the pad; all of it this far outside, from the ground [px].
  double sonar_footprint_margin_px = 4.0;
};

struct PadObservation {
  bool found = false;
  std::string reason;                    // why not found
  Detection detection;                   // what the image gave (pixels)
  HeightEstimate height;                 // camera height above the pad plane used
  Eigen::Vector3d centre_in_body = Eigen::Vector3d::Zero();        // pad centre - base_link, ardrone/base_link axes [m]
  Eigen::Vector3d centre_world_aligned = Eigen::Vector3d::Zero();  // the same vector in world axes [m]
  bool strip_found = false;
  Eigen::Vector3d strip_in_body = Eigen::Vector3d::Zero();         // strip centre - base_link, base_link axes [m]
  Eigen::Vector3d strip_world_aligned = Eigen::Vector3d::Zero();
  double pad_yaw = 0.0;                  // pad forward direction in the world, valid when strip_found [rad]
};

class PadLocalizer {
 public:
  PadLocalizer(const PadLocalizerParams& params, const CameraMount& mount);

  // From the sensors: sonar range [m] (NaN: none recent, +inf: nothing in range), barometric altitude of
  // base_link [m] (NaN: none), IMU attitude (world <- base_link), half the sonar's beam width [rad].
  PadObservation observe(const cv::Mat& image, ColorOrder order, const CameraIntrinsics& intrinsics,
                         const Eigen::Quaterniond& world_from_body, double sonar_range, double baro_altitude,
                         double sonar_half_angle = 0.0) const;

  // With the camera height above the pad plane given directly [m].
  PadObservation observeAtHeight(const cv::Mat& image, ColorOrder order, const CameraIntrinsics& intrinsics,
                                 const Eigen::Quaterniond& world_from_body, double camera_height) const;

  const PadDetector& detector() const { return detector_; }
  const PadHeightEstimator& heightEstimator() const { return height_estimator_; }

 private:
  // Which surface the sonar's first echo comes from, by the image: the pad when some of it lies within the
  // beam's footprint around the optical axis, the ground when all of it lies well outside.
  Surface surfaceUnderSonar(const Detection& detection, const CameraIntrinsics& intrinsics,
                            double sonar_half_angle) const;
  void locate(const PlaneView& view, PadObservation& observation) const;

  PadLocalizerParams params_;
  CameraMount mount_;
  PadDetector detector_;
  PadHeightEstimator height_estimator_;
};

}  // namespace uav_vision
