#include "uav_vision/pad_localizer.h"

#include <algorithm>
#include <cmath>

namespace uav_vision {

const char* toString(PadKind kind) { return kind == PadKind::kAprilTag ? "apriltag" : "red_square"; }

std::optional<PadKind> padKindFromString(const std::string& name) {
  if (name == "red_square") return PadKind::kRedSquare;
  if (name == "apriltag") return PadKind::kAprilTag;
  return std::nullopt;
}

PadLocalizer::PadLocalizer(const PadLocalizerParams& params, const CameraMount& mount)
    : params_(params),
      mount_(mount),
      detector_(params.detector),
      apriltag_(params.pad == PadKind::kAprilTag ? std::make_shared<const AprilTagPadDetector>(params.apriltag)
                                                 : nullptr),
      height_estimator_(params.height) {}

Surface PadLocalizer::surfaceUnderSonar(const Detection& detection, const CameraIntrinsics& intrinsics,
                                        double sonar_half_angle) const {
  if (!detection.found) return Surface::kUnknown;
  const double beam_px = std::max(intrinsics.fx, intrinsics.fy) * std::tan(std::clamp(sonar_half_angle, 0.0, 1.4));
  const double reach = detection.optical_axis_margin_px + beam_px;  // how far the beam reaches into the pad
  if (reach > params_.sonar_footprint_margin_px) return Surface::kPad;
  if (reach < -params_.sonar_footprint_margin_px) return Surface::kGround;
  return Surface::kUnknown;
}

void PadLocalizer::locate(const PlaneView& view, PadObservation& observation) const {
  const Detection& d = observation.detection;
  if (!d.found) {
    observation.reason = d.reason;
    return;
  }
  const auto centre = view.pixelToPlane(d.centre_px);
  if (!centre) {
    observation.reason = "pad centre does not project onto the pad plane";
    return;
  }
  observation.found = true;
  observation.centre_in_body = view.fromBaseInBody(*centre);
  observation.centre_world_aligned = view.fromBaseWorldAligned(*centre);
  if (d.strip_found) {
    if (const auto strip = view.pixelToPlane(d.strip_centre_px)) {
      observation.strip_found = true;
      observation.strip_in_body = view.fromBaseInBody(*strip);
      observation.strip_world_aligned = view.fromBaseWorldAligned(*strip);
      const Eigen::Vector2d forward = *strip - *centre;
      observation.pad_yaw = std::atan2(forward.y(), forward.x());
    }
  }
  if (d.pose_found) {
    const Eigen::Vector3d in_camera(d.pad_in_camera[0], d.pad_in_camera[1], d.pad_in_camera[2]);
    const Eigen::Vector3d forward_in_camera(d.pad_axes_in_camera(0, 0), d.pad_axes_in_camera(1, 0),
                                            d.pad_axes_in_camera(2, 0));
    observation.tag_pose_found = true;
    observation.tag_centre_in_body = mount_.optical_in_body * in_camera + mount_.position_in_body;
    if (apriltag_) {
      // The tags' pose: centre and heading point in base_link, turned into world axes by the IMU attitude.
      const Eigen::Vector3d heading_in_camera = in_camera + params_.apriltag.heading_offset * forward_in_camera;
      observation.centre_in_body = observation.tag_centre_in_body;
      observation.centre_world_aligned = view.worldFromBody() * observation.centre_in_body;
      observation.strip_found = true;
      observation.strip_in_body = mount_.optical_in_body * heading_in_camera + mount_.position_in_body;
      observation.strip_world_aligned = view.worldFromBody() * observation.strip_in_body;
      const Eigen::Vector3d forward = observation.strip_world_aligned - observation.centre_world_aligned;
      observation.pad_yaw = std::atan2(forward.y(), forward.x());
    }
  }
}

PadObservation PadLocalizer::observeAtHeight(const cv::Mat& image, ColorOrder order,
                                             const CameraIntrinsics& intrinsics,
                                             const Eigen::Quaterniond& world_from_body, double camera_height) const {
  PadObservation observation;
  observation.height.valid = true;
  observation.height.camera_height = camera_height;
  const PlaneView view(intrinsics, mount_, world_from_body, camera_height);
  if (!view.problem().empty()) {
    observation.reason = view.problem();
    return observation;
  }
  observation.detection = apriltag_ ? apriltag_->detect(image, order, &view) : detector_.detect(image, order, &view);
  locate(view, observation);
  return observation;
}

PadObservation PadLocalizer::observe(const cv::Mat& image, ColorOrder order, const CameraIntrinsics& intrinsics,
                                     const Eigen::Quaterniond& world_from_body, double sonar_range,
                                     double baro_altitude, double sonar_half_angle) const {
  HeightEstimate height =
      height_estimator_.estimate(sonar_range, baro_altitude, world_from_body, Surface::kUnknown, sonar_half_angle);
  if (!height.valid) {
    PadObservation observation;
    observation.height = height;
    observation.reason = "no camera height: " + height.reason;
    return observation;
  }
  PadObservation observation = observeAtHeight(image, order, intrinsics, world_from_body, height.camera_height);
  observation.height = height;
  if (height.ambiguous) {
    // The barometer cannot tell whether the sonar hits the pad or the ground; the image can, and a
    // wrong guess shows as a pad of the wrong size (whole) or a bad fit (partial).
    const Surface assumed = height.source == HeightEstimate::Source::kSonarOnPad ? Surface::kPad : Surface::kGround;
    const Surface seen = surfaceUnderSonar(observation.detection, intrinsics, sonar_half_angle);
    if (!observation.found || (seen != Surface::kUnknown && seen != assumed)) {
      const Surface other = assumed == Surface::kPad ? Surface::kGround : Surface::kPad;
      const HeightEstimate retry_height =
          height_estimator_.estimate(sonar_range, baro_altitude, world_from_body, other, sonar_half_angle);
      PadObservation retry =
          observeAtHeight(image, order, intrinsics, world_from_body, retry_height.camera_height);
      retry.height = retry_height;
      const Surface retry_seen = surfaceUnderSonar(retry.detection, intrinsics, sonar_half_angle);
      if (retry.found && (retry_seen == Surface::kUnknown || retry_seen == other)) return retry;
      if (observation.found) {
        // Found only at the height the image contradicts: its position would be off by the pad's height
        // over the camera's (12 % at 4 m).
        observation.found = false;
        observation.reason = "the image puts the sonar's echo on the " + std::string(seen == Surface::kPad ? "pad" : "ground") +
                             ", and the pad is found only at the height of the other surface";
      }
    }
  } else if (observation.found && height.source == HeightEstimate::Source::kSonarOnGround &&
             observation.detection.optical_axis_margin_px > params_.sonar_footprint_margin_px) {
    // The barometer says the sonar's echo comes from the ground, yet the red region covers the beam's axis:
    // the pad there, 0.5 m higher, would have echoed first. It lies on the ground: not the pad (the red
    // false target beside the vehicle). Only the axis: a pad at the rim of a wide beam echoes along a slant,
    // from further than it is below, and can pass for the ground.
    observation.found = false;
    observation.reason = "red region under the sonar, which sees the ground: not the pad";
  }
  return observation;
}

}  // namespace uav_vision
