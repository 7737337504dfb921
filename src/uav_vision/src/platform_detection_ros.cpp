#include "uav_vision/platform_detection_ros.h"

#include <algorithm>
#include <cmath>

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PointStamped.h>
#include <opencv2/imgproc.hpp>
#include <sensor_msgs/image_encodings.h>

namespace uav_vision {

namespace {
template <typename T>
T required(const ros::NodeHandle& pnh, const std::string& key) {
  T value;
  if (!pnh.hasParam(key))
    throw ConfigError("required parameter '" + pnh.resolveName(key) +
                      "' is missing: load config/platform_detection.yaml (see launch/platform_detection.launch)");
  if (!pnh.getParam(key, value))
    throw ConfigError("parameter '" + pnh.resolveName(key) + "' has the wrong type (see config/platform_detection.yaml)");
  return value;
}

void requirePositive(const ros::NodeHandle& pnh, const std::string& key, double value) {
  if (!(std::isfinite(value) && value > 0.0))
    throw ConfigError("parameter '" + pnh.resolveName(key) + "' must be a positive number of seconds");
}

// camera_info's D as plumb_bob coefficients into `distortion`; empty when usable, else what is wrong.
std::string lensDistortion(const std::string& model, const std::vector<double>& d, std::array<double, 5>& distortion) {
  distortion.fill(0.0);
  const bool all_zero = std::all_of(d.begin(), d.end(), [](double v) { return v == 0.0; });
  if (all_zero) return "";  // a perfect lens, whatever the model's name
  if (model != "plumb_bob")
    return "distortion model '" + model + "' is not supported (plumb_bob: D = k1, k2, p1, p2, k3)";
  if (d.size() != 5)
    return "plumb_bob needs 5 distortion coefficients (k1, k2, p1, p2, k3), D has " + std::to_string(d.size());
  for (size_t i = 0; i < d.size(); ++i) {
    if (!std::isfinite(d[i])) return "D[" + std::to_string(i) + "] is not a finite number";
    distortion[i] = d[i];
  }
  return "";
}

geometry_msgs::PointStamped pointMsg(const std_msgs::Header& image_header, const std::string& frame,
                                     const Eigen::Vector3d& p) {
  geometry_msgs::PointStamped msg;
  msg.header.stamp = image_header.stamp;
  msg.header.frame_id = frame;
  msg.point.x = p.x();
  msg.point.y = p.y();
  msg.point.z = p.z();
  return msg;
}

}  // namespace

PlatformDetectionConfig PlatformDetectionConfig::load(const ros::NodeHandle& pnh) {
  PlatformDetectionConfig c;
  auto num = [&](const std::string& key) { return required<double>(pnh, key); };
  auto integer = [&](const std::string& key) { return required<int>(pnh, key); };
  auto& h = c.localizer.height;
  h.height_landing_platform = num("height_landing_platform");
  c.base_frame = required<std::string>(pnh, "frames/base");
  c.world_frame = required<std::string>(pnh, "frames/world");
  auto& d = c.localizer.detector;
  d.pad.side = num("pad/side");
  d.pad.strip_length = num("pad/strip_length");
  d.pad.strip_width = num("pad/strip_width");
  d.pad.strip_offset = num("pad/strip_offset");
  d.pad.marker_side = num("pad/marker_side");
  h.camera_below_base_link = num("drone/camera_below_base_link");
  h.sonar_below_base_link = num("drone/sonar_below_base_link");
  h.sonar_max_range = num("drone/sonar_max_range");
  h.baro_tolerance = num("drone/baro_tolerance");
  h.max_tilt_deg = num("drone/max_tilt_deg");
  d.red_margin_min = integer("colour/red_margin_min");
  d.green_margin_min = integer("colour/green_margin_min");
  d.marker_chroma_max = integer("colour/marker_chroma_max");
  d.marker_value_min = integer("colour/marker_value_min");
  d.morphology_kernel_px = integer("shape/morphology_kernel_px");
  d.min_area_px = num("shape/min_area_px");
  d.min_solidity = num("shape/min_solidity");
  d.approx_epsilon = num("shape/approx_epsilon");
  d.max_side_ratio = num("shape/max_side_ratio");
  d.max_corner_angle_error_deg = num("shape/max_corner_angle_error_deg");
  d.size_tolerance = num("shape/size_tolerance");
  d.max_edge_angle_error_deg = num("shape/max_edge_angle_error_deg");
  d.border_margin_px = num("shape/border_margin_px");
  d.min_edge_length_px = num("shape/min_edge_length_px");
  d.fit_tolerance_m = num("shape/fit_tolerance_m");
  d.min_partial_support_px = num("shape/min_partial_support_px");
  d.min_partial_coverage = num("shape/min_partial_coverage");
  d.min_corner_image_share = num("shape/min_corner_image_share");
  d.max_off_edge_share = num("shape/max_off_edge_share");
  d.edge_gap_tolerance = num("shape/edge_gap_tolerance");
  d.min_strip_area_px = num("shape/min_strip_area_px");
  d.marker_min_surround = num("shape/marker_min_surround");
  c.localizer.sonar_footprint_margin_px = num("shape/sonar_footprint_margin_px");
  c.odom_timeout = num("timing/odom_timeout");
  c.imu_max_offset = num("timing/imu_max_offset");
  c.sonar_timeout = num("timing/sonar_timeout");
  c.altimeter_timeout = num("timing/altimeter_timeout");
  c.altimeter_window = num("timing/altimeter_window");
  c.warn_period = num("timing/warn_period");
  for (const char* key : {"timing/odom_timeout", "timing/imu_max_offset", "timing/sonar_timeout",
                          "timing/altimeter_timeout", "timing/altimeter_window", "timing/warn_period"})
    requirePositive(pnh, key, num(key));
  if (c.base_frame.empty() || c.world_frame.empty())
    throw ConfigError("parameters '" + pnh.resolveName("frames") + "/base' and '/world' must not be empty");
  if (const std::string problem = PadDetector::validate(d); !problem.empty())
    throw ConfigError("invalid detector parameter in " + pnh.getNamespace() + ": " + problem);
  // Which pad to look for; the AprilTag pad's keys are read (and required) only for it.
  const std::string detector = required<std::string>(pnh, "detector");
  const std::optional<PadKind> kind = padKindFromString(detector);
  if (!kind)
    throw ConfigError("parameter '" + pnh.resolveName("detector") + "' is '" + detector +
                      "': expected red_square or apriltag (launch/platform_detection.launch sets it from its pad argument)");
  c.localizer.pad = *kind;
  if (*kind == PadKind::kAprilTag) {
    auto& a = c.localizer.apriltag;
    for (const auto& [key, tag] : {std::pair<std::string, TagSpec*>{"apriltag/outer", &a.layout.outer},
                                   {"apriltag/inner", &a.layout.inner}}) {
      tag->family = required<std::string>(pnh, key + "/family");
      tag->id = integer(key + "/id");
      tag->size = num(key + "/size");
    }
    a.heading_offset = num("apriltag/heading_offset");
    a.max_hamming = integer("apriltag/max_hamming");
    a.min_decision_margin = num("apriltag/min_decision_margin");
    a.shadow_lift = num("apriltag/shadow_lift");
    a.denoise_sigma = num("apriltag/denoise_sigma");
    a.quad_decimate = num("apriltag/quad_decimate");
    a.close_quad_decimate = num("apriltag/close_quad_decimate");
    a.close_height = num("apriltag/close_height");
    a.quad_sigma = num("apriltag/quad_sigma");
    a.min_white_black_diff = integer("apriltag/min_white_black_diff");
    a.min_cluster_pixels = integer("apriltag/min_cluster_pixels");
    a.decode_sharpening = num("apriltag/decode_sharpening");
    a.size_tolerance = num("apriltag/size_tolerance");
    a.max_layout_error_px = num("apriltag/max_layout_error_px");
    a.min_cell_px = num("apriltag/min_cell_px");
    if (const std::string problem = AprilTagPadDetector::validate(a); !problem.empty())
      throw ConfigError("invalid AprilTag pad parameter in " + pnh.getNamespace() + ": " + problem +
                        " (see config/platform_detection.yaml)");
  }
  if (const std::string problem = PadHeightEstimator::validate(h); !problem.empty())
    throw ConfigError("invalid height parameter in " + pnh.getNamespace() + ": " + problem);
  return c;
}

DetectionState::DetectionState(const PlatformDetectionConfig& config)
    : config(config),
      localizer(config.localizer, CameraMount::bottomCamera(config.localizer.height.camera_below_base_link)),
      attitudes(config.imu_max_offset),
      estimates(config.odom_timeout) {}

PlatformDetectionRos::PlatformDetectionRos(ros::NodeHandle nh, ros::NodeHandle pnh)
    : pnh_(pnh),
      state_(PlatformDetectionConfig::load(pnh)),
      image_transport_(nh),
      lockstep_(nh, "ardrone/bottom/image_raw") {
  rejections_.emplace();
  platform_in_base_pub_ = nh.advertise<geometry_msgs::PointStamped>("platform/current_platform_position_in_ardrone", 10);
  platform_in_world_pub_ = nh.advertise<geometry_msgs::PointStamped>("platform/current_platform_position_in_world", 10);
  indicator_in_base_pub_ =
      nh.advertise<geometry_msgs::PointStamped>("platform/current_indicator_position_in_ardrone", 10);
  debug_pub_ = image_transport_.advertise("platform_detection/debug_image", 1);
  // Nagle's algorithm would deliver the drone's state in bursts, late for the image it locates the pad with.
  const ros::TransportHints no_delay = ros::TransportHints().tcpNoDelay();
  camera_info_sub_ = nh.subscribe("ardrone/bottom/camera_info", 5, &PlatformDetectionRos::onCameraInfo, this);
  imu_sub_ = nh.subscribe("ardrone/imu", 50, &PlatformDetectionRos::onImu, this, no_delay);
  sonar_sub_ = nh.subscribe("ardrone/sonar_height", 10, &PlatformDetectionRos::onSonar, this, no_delay);
  altimeter_sub_ = nh.subscribe("ardrone/altimeter", 10, &PlatformDetectionRos::onAltimeter, this, no_delay);
  odom_sub_ = nh.subscribe("ardrone/odom_estimate", 10, &PlatformDetectionRos::onOdomEstimate, this, no_delay);
  // Queue of one: always work on the newest frame, never on a backlog.
  image_sub_ = image_transport_.subscribe("ardrone/bottom/image_raw", 1, &PlatformDetectionRos::onImage, this,
                                          image_transport::TransportHints("raw", no_delay));
  reset_service_ = pnh_.advertiseService("reset", &PlatformDetectionRos::onReset, this);
  const auto& localizer = state_.config.localizer;
  if (localizer.pad == PadKind::kAprilTag)
    ROS_INFO("platform_detection: looking for the AprilTag pad (%s %d of %.3f m, %s %d of %.3f m at its centre) whose "
             "top is %.3f m above the ground",
             localizer.apriltag.layout.outer.family.c_str(), localizer.apriltag.layout.outer.id,
             localizer.apriltag.layout.outer.size, localizer.apriltag.layout.inner.family.c_str(),
             localizer.apriltag.layout.inner.id, localizer.apriltag.layout.inner.size,
             localizer.height.height_landing_platform);
  else
    ROS_INFO("platform_detection: looking for a %.2f m red pad whose top is %.3f m above the ground",
             localizer.detector.pad.side, localizer.height.height_landing_platform);
}

bool PlatformDetectionRos::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  const std::string node = ros::this_node::getName();
  try {
    // Built whole before it replaces the old state: a refused reset leaves the node as it was.
    DetectionState fresh(PlatformDetectionConfig::load(pnh_));
    state_ = std::move(fresh);
  } catch (const std::exception& error) {  // ConfigError; anything the detector's set-up refuses
    response.success = false;
    response.message = node + " not reset (it goes on as it was): " + error.what();
    ROS_ERROR("%s", response.message.c_str());
    return true;
  }
  rejections_.emplace();
  response.success = true;
  response.message = node + " reset";
  ROS_INFO("%s", response.message.c_str());
  return true;
}

void PlatformDetectionRos::onCameraInfo(const sensor_msgs::CameraInfoConstPtr& msg) {
  CameraIntrinsics k;
  k.fx = msg->K[0];
  k.fy = msg->K[4];
  k.cx = msg->K[2];
  k.cy = msg->K[5];
  k.width = int(msg->width);
  k.height = int(msg->height);
  std::string problem = lensDistortion(msg->distortion_model, msg->D, k.distortion);
  if (problem.empty()) problem = k.problem();
  if (!problem.empty()) {
    ROS_WARN_THROTTLE(state_.config.warn_period, "%s: dropped (the last good one still serves): %s",
                      camera_info_sub_.getTopic().c_str(), problem.c_str());
    return;
  }
  state_.intrinsics = k;
}

void PlatformDetectionRos::onImu(const sensor_msgs::ImuConstPtr& msg) {
  const auto& o = msg->orientation;
  const Eigen::Quaterniond q(o.w, o.x, o.y, o.z);
  // covariance[0] == -1 means "no orientation" (REP 145).
  if (!(q.coeffs().allFinite() && std::abs(q.norm() - 1.0) < 0.1) || msg->orientation_covariance[0] == -1.0) {
    ROS_WARN_THROTTLE(state_.config.warn_period, "%s: dropped a message without a valid orientation quaternion",
                      imu_sub_.getTopic().c_str());
    return;
  }
  const auto& w = msg->angular_velocity;
  if (auto problem = inputProblem(msg->header, state_.config.base_frame))
    return rejections_->reject(imu_sub_.getTopic(), *problem);
  for (const auto& [name, value] : {std::pair<const char*, double>{"angular_velocity.x", w.x}, {"angular_velocity.y", w.y},
                                    {"angular_velocity.z", w.z}})
    if (auto problem = landing_runtime::numberProblem(name, value, landing_runtime::kMaxRateRadps))
      return rejections_->reject(imu_sub_.getTopic(), *problem);
  // angular_velocity_covariance[0] == -1: no rates (REP 145); the attitude is then held between samples.
  const Eigen::Vector3d body_rate = msg->angular_velocity_covariance[0] == -1.0 ? Eigen::Vector3d::Zero()
                                                                                 : Eigen::Vector3d(w.x, w.y, w.z);
  state_.attitudes.add(msg->header.stamp.toSec(), q, body_rate);  // a stamp going back restarts the history
}

void PlatformDetectionRos::onSonar(const sensor_msgs::RangeConstPtr& msg) {
  // +inf is a valid reading (nothing in range); NaN or negative is not.
  if (std::isnan(msg->range) || msg->range < 0.0) {
    ROS_WARN_THROTTLE(state_.config.warn_period, "%s: dropped an invalid range %f", sonar_sub_.getTopic().c_str(),
                      msg->range);
    return;
  }
  if (auto problem = inputProblem(msg->header, state_.config.base_frame))
    return rejections_->reject(sonar_sub_.getTopic(), *problem);
  if (!(msg->field_of_view >= 0.0 && msg->field_of_view < M_PI)) {
    ROS_WARN_THROTTLE(state_.config.warn_period, "%s: dropped a reading whose field_of_view %f is not in [0, pi) rad",
                      sonar_sub_.getTopic().c_str(), msg->field_of_view);
    return;
  }
  state_.sonar_ranges.add(msg->header.stamp.toSec(), msg->range);
  state_.sonar_half_angle = 0.5 * msg->field_of_view;
}

void PlatformDetectionRos::onAltimeter(const landing_msgs::AltimeterConstPtr& msg) {
  if (!std::isfinite(msg->altitude)) {
    ROS_WARN_THROTTLE(state_.config.warn_period, "%s: dropped a non-finite altitude",
                      altimeter_sub_.getTopic().c_str());
    return;
  }
  if (auto problem = landing_runtime::numberProblem("altitude", msg->altitude, landing_runtime::kMaxAltitudeM))
    return rejections_->reject(altimeter_sub_.getTopic(), *problem);
  if (auto problem = inputProblem(msg->header, ""))  // an altitude above the ground: any frame
    return rejections_->reject(altimeter_sub_.getTopic(), *problem);
  state_.altitudes.add(msg->header.stamp.toSec(), msg->altitude);
}

void PlatformDetectionRos::onOdomEstimate(const nav_msgs::OdometryConstPtr& msg) {
  const auto& p = msg->pose.pose.position;
  if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) {
    ROS_WARN_THROTTLE(state_.config.warn_period, "%s: dropped a non-finite position", odom_sub_.getTopic().c_str());
    return;
  }
  if (!msg->header.frame_id.empty() && msg->header.frame_id != state_.config.world_frame) {
    ROS_WARN_THROTTLE(state_.config.warn_period, "%s: dropped: position in frame '%s', expected '%s'",
                      odom_sub_.getTopic().c_str(), msg->header.frame_id.c_str(), state_.config.world_frame.c_str());
    return;
  }
  for (const auto& [name, value] : {std::pair<const char*, double>{"position.x", p.x}, {"position.y", p.y}, {"position.z", p.z}})
    if (auto problem = landing_runtime::numberProblem(name, value, landing_runtime::kMaxPositionM))
      return rejections_->reject(odom_sub_.getTopic(), *problem);
  if (auto problem = inputProblem(msg->header, "")) return rejections_->reject(odom_sub_.getTopic(), *problem);
  const auto& v = msg->twist.twist.linear;
  const Eigen::Vector3d velocity =
      std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) &&
              Eigen::Vector3d(v.x, v.y, v.z).norm() <= landing_runtime::kMaxSpeedMps
          ? Eigen::Vector3d(v.x, v.y, v.z)
          : Eigen::Vector3d::Zero();
  // The estimator publishes the IMU's attitude turned by the yaw drift it has learnt: what turns this frame's
  // IMU-aligned vector into the world the estimate (and the tracker) lives in.
  const double stamp = msg->header.stamp.toSec();
  double heading_turn = 0.0;
  const auto& q = msg->pose.pose.orientation;
  const auto imu = state_.attitudes.at(stamp);
  if (imu && std::isfinite(q.w) && std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z) &&
      q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z > 0.25)
    heading_turn = headingTurn(Eigen::Quaterniond(q.w, q.x, q.y, q.z), *imu);
  state_.estimates.add({stamp, Eigen::Vector3d(p.x, p.y, p.z), velocity, heading_turn});
}

std::optional<landing_runtime::InputProblem> PlatformDetectionRos::inputProblem(const std_msgs::Header& header,
                                                                           const std::string& frame) const {
  if (auto problem = landing_runtime::stampProblem(header.stamp, ros::Time::now())) return problem;
  if (!frame.empty()) return landing_runtime::frameProblem(header.frame_id, frame);
  return std::nullopt;
}

void PlatformDetectionRos::onImage(const sensor_msgs::ImageConstPtr& msg) {
  processImage(msg);
  lockstep_.ack(msg->header.stamp);  // processed or dropped: either way the simulator may go on
}

void PlatformDetectionRos::processImage(const sensor_msgs::ImageConstPtr& msg) {
  namespace enc = sensor_msgs::image_encodings;
  const double period = state_.config.warn_period;
  const std::string topic_name = image_sub_.getTopic();
  const char* topic = topic_name.c_str();
  ColorOrder order;
  if (msg->encoding == enc::RGB8) {
    order = ColorOrder::kRgb;
  } else if (msg->encoding == enc::BGR8) {
    order = ColorOrder::kBgr;
  } else {
    ROS_WARN_THROTTLE(period, "%s: dropped a frame with encoding '%s' (rgb8 or bgr8 expected)", topic,
                      msg->encoding.c_str());
    return;
  }
  if (msg->width == 0 || msg->height == 0 || msg->step < msg->width * 3 ||
      msg->data.size() < size_t(msg->step) * msg->height) {
    ROS_WARN_THROTTLE(period, "%s: dropped a %ux%u frame whose step (%u) or data size (%zu) does not fit", topic,
                      msg->width, msg->height, msg->step, msg->data.size());
    return;
  }
  if (auto problem = inputProblem(msg->header, "")) {
    rejections_->reject(topic_name, *problem);
    return;
  }
  if (!state_.intrinsics) {
    ROS_WARN_THROTTLE(period, "%s: no valid %s yet: frame dropped", topic, camera_info_sub_.getTopic().c_str());
    return;
  }
  if (int(msg->width) != state_.intrinsics->width || int(msg->height) != state_.intrinsics->height) {
    ROS_WARN_THROTTLE(period, "%s: dropped a %ux%u frame: %s is for %dx%d", topic, msg->width, msg->height,
                      camera_info_sub_.getTopic().c_str(), state_.intrinsics->width, state_.intrinsics->height);
    return;
  }
  const ros::Time stamp = msg->header.stamp;
  const auto attitude = state_.attitudes.at(stamp.toSec());
  if (!attitude) {
    ROS_WARN_THROTTLE(period, "%s: no %s within %.3f s of the frame: dropped", topic, imu_sub_.getTopic().c_str(),
                      state_.config.imu_max_offset);
    return;
  }
  // The readings of the frame's capture time, not the newest: the frame is 100-200 ms old.
  const double sonar = state_.sonar_ranges.medianNear(stamp.toSec(), state_.config.sonar_timeout);
  const double altitude =
      state_.altitudes.meanNear(stamp.toSec(), state_.config.altimeter_window, state_.config.altimeter_timeout);
  if (std::isnan(sonar) && std::isnan(altitude)) {
    ROS_WARN_THROTTLE(period, "%s: no %s or %s within %.2f s / %.2f s of the frame to give the height: dropped", topic,
                      sonar_sub_.getTopic().c_str(), altimeter_sub_.getTopic().c_str(), state_.config.sonar_timeout,
                      state_.config.altimeter_timeout);
    return;
  }
  cv_bridge::CvImageConstPtr image;
  try {
    image = cv_bridge::toCvShare(msg);
  } catch (const cv_bridge::Exception& e) {
    ROS_WARN_THROTTLE(period, "%s: dropped a frame cv_bridge cannot read: %s", topic, e.what());
    return;
  }
  // Inputs that pass every check may still be ones OpenCV refuses (a lens or an image no camera makes): the
  // frame is dropped with the reason, the node goes on (an exception out of a callback would abort it).
  try {
    const PadObservation observation =
        state_.localizer.observe(image->image, order, *state_.intrinsics, *attitude, sonar, altitude,
                                 state_.sonar_half_angle);
    if (observation.found)
      publish(msg->header, observation);
    else
      ROS_DEBUG_THROTTLE(1.0, "no pad: %s", observation.reason.c_str());
    if (debug_pub_.getNumSubscribers() > 0) publishDebugImage(msg, image->image, observation, *state_.intrinsics);
  } catch (const std::exception& e) {
    ROS_WARN_THROTTLE(period, "%s: dropped a frame the detector could not process: %s", topic, e.what());
  }
}

void PlatformDetectionRos::publish(const std_msgs::Header& image_header, const PadObservation& observation) {
  platform_in_base_pub_.publish(pointMsg(image_header, state_.config.base_frame, observation.centre_in_body));
  if (observation.strip_found)
    indicator_in_base_pub_.publish(pointMsg(image_header, state_.config.base_frame, observation.strip_in_body));
  const std::optional<DroneEstimate> drone = state_.estimates.at(image_header.stamp.toSec());
  if (!drone) {
    ROS_WARN_THROTTLE(state_.config.warn_period,
                      "no %s within %.2f s of the frame: publishing the relative pad position only",
                      odom_sub_.getTopic().c_str(), state_.config.odom_timeout);
    return;
  }
  // The IMU attitude turned the vector to its own world axes, whose yaw drifts; the estimate's heading corrects it.
  const Eigen::Vector3d offset = Eigen::AngleAxisd(drone->heading_turn, Eigen::Vector3d::UnitZ()) *
                                 observation.centre_world_aligned;
  platform_in_world_pub_.publish(pointMsg(image_header, state_.config.world_frame, drone->position + offset));
}

void PlatformDetectionRos::publishDebugImage(const sensor_msgs::ImageConstPtr& msg, const cv::Mat& image,
                                             const PadObservation& observation, const CameraIntrinsics& intrinsics) {
  cv::Mat canvas = image.clone();
  const bool rgb = msg->encoding == sensor_msgs::image_encodings::RGB8;
  auto colour = [rgb](int b, int g, int r) { return rgb ? cv::Scalar(r, g, b) : cv::Scalar(b, g, r); };
  const Detection& d = observation.detection;
  cv::drawMarker(canvas, cv::Point2d(intrinsics.cx, intrinsics.cy), colour(255, 255, 255), cv::MARKER_CROSS, 8, 1);
  if (!d.outline.empty())
    cv::polylines(canvas, std::vector<std::vector<cv::Point>>{d.outline}, true, colour(0, 255, 255), 1);
  std::string text;
  // The detection's points are ideal (undistorted) pixels: put them back through the lens.
  auto onImage = [&](const cv::Point2d& ideal) { return distortPixel(intrinsics, ideal); };
  if (observation.found) {
    for (int k = 0; k < 4; ++k)
      cv::line(canvas, onImage(d.corners_px[k]), onImage(d.corners_px[(k + 1) % 4]), colour(255, 0, 255), 1,
               cv::LINE_AA);
    cv::drawMarker(canvas, onImage(d.centre_px), colour(255, 255, 0), cv::MARKER_CROSS, 12, 2);
    if (d.strip_found) cv::circle(canvas, onImage(d.strip_centre_px), 4, colour(0, 255, 0), 2);
    char buffer[128];
    const bool tags = state_.config.localizer.pad == PadKind::kAprilTag;
    std::snprintf(buffer, sizeof(buffer), "%s x=%.2f y=%.2f h=%.2f q=%.2f",
                  d.marker ? (tags ? "inner tag" : "marker") : d.partial ? "partial" : tags ? "tags" : "pad",
                  observation.centre_in_body.x(), observation.centre_in_body.y(), observation.height.camera_height,
                  d.quality);
    text = buffer;
  } else {
    text = observation.reason;
  }
  cv::putText(canvas, text, {4, canvas.rows - 6}, cv::FONT_HERSHEY_SIMPLEX, 0.35, colour(255, 255, 255), 1, cv::LINE_AA);
  debug_pub_.publish(cv_bridge::CvImage(msg->header, msg->encoding, canvas).toImageMsg());
}

}  // namespace uav_vision
