#include "uav_vision/pad_height_estimator.h"

#include <algorithm>
#include <cmath>

namespace uav_vision {

const char* toString(HeightEstimate::Source source) {
  switch (source) {
    case HeightEstimate::Source::kSonarOnPad: return "sonar on the pad";
    case HeightEstimate::Source::kSonarOnGround: return "sonar on the ground";
    case HeightEstimate::Source::kBarometer: return "barometer";
    default: return "none";
  }
}

std::string PadHeightEstimator::validate(const PadHeightParams& p) {
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (!in(p.height_landing_platform, 0.0, 20.0)) return "height_landing_platform must be in [0, 20] m";
  if (!in(p.sonar_below_base_link, -1.0, 1.0)) return "sonar_below_base_link must be in [-1, 1] m";
  if (!in(p.camera_below_base_link, -1.0, 1.0)) return "camera_below_base_link must be in [-1, 1] m";
  if (!in(p.sonar_max_range, 0.1, 100.0)) return "sonar_max_range must be in [0.1, 100] m";
  if (!in(p.baro_tolerance, 0.01, 10.0)) return "baro_tolerance must be in [0.01, 10] m";
  if (!in(p.max_tilt_deg, 0.0, 80.0)) return "max_tilt_deg must be in [0, 80] deg";
  return "";
}

HeightEstimate PadHeightEstimator::estimate(double sonar_range, double baro_altitude,
                                            const Eigen::Quaterniond& world_from_body, Surface hint,
                                            double sonar_half_angle) const {
  const auto& p = params_;
  HeightEstimate result;
  if (!(world_from_body.coeffs().allFinite() && world_from_body.norm() > 0.5)) {
    result.reason = "attitude not finite";
    return result;
  }
  // Cosine of the tilt: the body z axis' vertical component. Lengths along body z shrink by it.
  const double cos_tilt = world_from_body.normalized().toRotationMatrix()(2, 2);
  const bool have_baro = std::isfinite(baro_altitude);
  const double from_baro =
      have_baro ? baro_altitude - p.camera_below_base_link * cos_tilt - p.height_landing_platform : NAN;

  const bool sonar_usable = std::isfinite(sonar_range) && sonar_range >= 0.0 && sonar_range <= p.sonar_max_range &&
                            cos_tilt >= std::cos(p.max_tilt_deg * M_PI / 180.0);
  if (sonar_usable) {
    // The echo's path leans from the vertical by what of the tilt the beam does not cover (all of it for a
    // narrow beam). The camera sits on the sonar's axis, (sonar - camera offset) closer to the surface.
    const double slant = std::max(0.0, std::acos(std::min(1.0, cos_tilt)) - std::max(0.0, sonar_half_angle));
    const double camera_above_surface =
        sonar_range * std::cos(slant) + (p.sonar_below_base_link - p.camera_below_base_link) * cos_tilt;
    const double if_pad = camera_above_surface;
    const double if_ground = camera_above_surface - p.height_landing_platform;
    // With no barometer every hypothesis is plausible; a negative height is never.
    const bool pad_ok = if_pad > 0.0 && (!have_baro || std::abs(if_pad - from_baro) <= p.baro_tolerance);
    const bool ground_ok = if_ground > 0.0 && (!have_baro || std::abs(if_ground - from_baro) <= p.baro_tolerance);
    auto take = [&](bool on_pad) {
      result.valid = true;
      result.camera_height = on_pad ? if_pad : if_ground;
      result.source = on_pad ? HeightEstimate::Source::kSonarOnPad : HeightEstimate::Source::kSonarOnGround;
      result.ambiguous = pad_ok && ground_ok;
      result.alternative = on_pad ? if_ground : if_pad;
      return result;
    };
    if (pad_ok && ground_ok) {
      if (hint == Surface::kPad) return take(true);
      if (hint == Surface::kGround) return take(false);
      return take(!have_baro || std::abs(if_pad - from_baro) <= std::abs(if_ground - from_baro));
    }
    if (pad_ok) return take(true);
    if (ground_ok) return take(false);
    // The sonar sees something else (the vehicle's body, an obstacle): fall back to the barometer.
  }
  if (have_baro && from_baro > 0.0) {
    result.valid = true;
    result.camera_height = from_baro;
    result.source = HeightEstimate::Source::kBarometer;
    return result;
  }
  result.reason = have_baro ? "barometer puts the camera below the pad" : "no sonar or barometer reading";
  return result;
}

}  // namespace uav_vision
