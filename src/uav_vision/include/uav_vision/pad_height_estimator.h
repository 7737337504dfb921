// Camera height above the pad plane from the drone's own sensors (ROS-free).
//
// The sonar measures along body -z to whatever is below: the pad or the ground, which differ by the
// pad's height. Each gives a hypothesis for the camera height above the pad; the barometric altitude
// (noisy, ~0.1 m) rules out the implausible one, and an image hint (is the sonar's footprint on the
// detected pad?) picks between two plausible ones. Without a usable sonar, the barometer alone.
#pragma once

#include <string>

#include <Eigen/Geometry>

namespace uav_vision {

struct PadHeightParams {
  double height_landing_platform = 0.497;  // pad top above the ground [m]
  double sonar_below_base_link = 0.065;    // sonar range origin below base_link, along body z [m]
  double camera_below_base_link = 0.035;   // camera optical centre below base_link, along body z [m]
  double sonar_max_range = 6.0;            // readings beyond (or +inf) mean nothing in range [m]
  double baro_tolerance = 0.35;            // a sonar hypothesis further than this from the barometer is rejected [m]
  double max_tilt_deg = 40.0;              // beyond this tilt the sonar is not trusted [deg]
};

enum class Surface { kUnknown, kPad, kGround };

struct HeightEstimate {
  enum class Source { kNone, kSonarOnPad, kSonarOnGround, kBarometer };
  bool valid = false;
  double camera_height = 0.0;  // optical centre above the pad plane [m]
  Source source = Source::kNone;
  bool ambiguous = false;      // both sonar hypotheses agree with the barometer: the image hint decides
  double alternative = 0.0;    // the other sonar hypothesis when ambiguous [m]
  std::string reason;          // why not valid
};

const char* toString(HeightEstimate::Source source);

class PadHeightEstimator {
 public:
  explicit PadHeightEstimator(const PadHeightParams& params = PadHeightParams()) : params_(params) {}

  static std::string validate(const PadHeightParams& params);

  // sonar_range: ardrone/sonar_height range [m] (NaN when no recent reading, +inf when nothing in range);
  // baro_altitude: base_link above the ground [m] (NaN when none); world_from_body: IMU attitude.
  // hint: which surface the sonar points at according to the image (kUnknown if not known).
  // sonar_half_angle: half the sonar's beam (sensor_msgs/Range field_of_view / 2) [rad]. A wide beam's first
  // echo comes from the nearest point of the surface within it: straight below while the tilt is within
  // the beam, else from the beam's edge nearest to the vertical; a narrow one (0) measures along body -z.
  HeightEstimate estimate(double sonar_range, double baro_altitude, const Eigen::Quaterniond& world_from_body,
                          Surface hint = Surface::kUnknown, double sonar_half_angle = 0.0) const;

  const PadHeightParams& params() const { return params_; }

 private:
  PadHeightParams params_;
};

}  // namespace uav_vision
