// Pad position relative to the drone from one camera frame and the drone's own sensors (ROS-free):
// detector + height estimator + back-projection onto the pad plane.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "uav_vision/apriltag_pad_detector.h"
#include "uav_vision/camera_geometry.h"
#include "uav_vision/pad_detector.h"
#include "uav_vision/pad_height_estimator.h"

namespace uav_vision {

// Which pad the localizer looks for: the red square (PadDetector) or the AprilTag pad (AprilTagPadDetector).
enum class PadKind { kRedSquare, kAprilTag };
const char* toString(PadKind kind);                                  // "red_square", "apriltag"
std::optional<PadKind> padKindFromString(const std::string& name);  // nothing for an unknown name

struct PadLocalizerParams {
  PadKind pad = PadKind::kRedSquare;
  PadDetectorParams detector;   // the red square's (pad == kRedSquare)
  AprilTagPadParams apriltag;   // the AprilTag pad's (pad == kAprilTag)
  PadHeightParams height;
  // The sonar's beam (around the optical axis) reaching this far inside the pad outline means its echo comes
  // from the pad; all of it this far outside, from the ground [px].
  double sonar_footprint_margin_px = 4.0;
};

// The AprilTag pad's centre and heading point come from the tags' pose (their known sizes and K: the camera is the
// drone's own sensor) when it is found: it needs neither the height nor the IMU in base_link axes, and its error was a
// quarter of the back-projection's at the height of the sonar and barometer (issue 44's benchmark). The height still
// checks the tags' sizes (a wrong sonar hypothesis, another print of a pad tag), and the IMU turns the vectors into
// world axes.
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
  // AprilTag pad: the centre from the tags' pose alone (their known sizes and K; no sonar, barometer or IMU).
  bool tag_pose_found = false;
  Eigen::Vector3d tag_centre_in_body = Eigen::Vector3d::Zero();    // pad centre - base_link, base_link axes [m]
};

// Copies share the AprilTag detector (one thread at a time, as the node's one spinner thread).
class PadLocalizer {
 public:
  // Throws std::invalid_argument when the AprilTag pad's parameters are invalid (AprilTagPadDetector::validate).
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
  // The AprilTag detector, null for the red square.
  const AprilTagPadDetector* apriltagDetector() const { return apriltag_.get(); }
  PadKind pad() const { return params_.pad; }
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
  std::shared_ptr<const AprilTagPadDetector> apriltag_;
  PadHeightEstimator height_estimator_;
};

}  // namespace uav_vision
