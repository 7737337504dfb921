#include "uav_vision/rendered_frames.h"

#include "uav_vision/reading_history.h"

#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace uav_vision {

std::vector<RenderedFrame> loadRenderedFrames(const std::string& dir) {
  const std::string path = dir + "/truth.csv";
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path + " (make it with src/landing_bench/test/render_fixtures.py)");
  auto cells = [](std::string line) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::vector<std::string> out;
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) out.push_back(cell);
    return out;
  };
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> header = cells(line);
  std::vector<RenderedFrame> frames;
  for (int line_number = 2; std::getline(in, line); ++line_number) {
    if (line.empty() || line == "\r") continue;
    const std::vector<std::string> values = cells(line);
    if (values.size() != header.size())
      throw std::runtime_error(path + ":" + std::to_string(line_number) + ": " + std::to_string(values.size()) +
                               " values for " + std::to_string(header.size()) + " columns");
    std::map<std::string, std::string> row;
    for (size_t i = 0; i < header.size(); ++i) row[header[i]] = values[i];
    auto text = [&](const std::string& key) {
      const auto it = row.find(key);
      if (it == row.end()) throw std::runtime_error(path + ": no column " + key + " (re-render with src/landing_bench/test/render_fixtures.py)");
      return it->second;
    };
    auto num = [&](const std::string& key) {
      const std::string value = text(key);
      try {
        return std::stod(value);
      } catch (const std::exception&) {
        throw std::runtime_error(path + ":" + std::to_string(line_number) + ": column " + key + " is not a number: '" +
                                 value + "'");
      }
    };
    auto vec = [&](const std::string& prefix) {
      return Eigen::Vector3d(num(prefix + "_x"), num(prefix + "_y"), num(prefix + "_z"));
    };
    RenderedFrame f;
    f.image = text("image");
    f.band = text("band");
    f.vehicle = text("vehicle");
    f.profile = text("profile");
    f.height_landing_platform = num("height_landing_platform");
    f.camera_height = num("camera_height");
    f.intrinsics.fx = num("fx");
    f.intrinsics.fy = num("fy");
    f.intrinsics.cx = num("cx");
    f.intrinsics.cy = num("cy");
    f.intrinsics.width = int(num("width"));
    f.intrinsics.height = int(num("height"));
    f.intrinsics.distortion = {num("k1"), num("k2"), num("p1"), num("p2"), num("k3")};
    f.pad_in_body = vec("pad_base");
    f.pad_world_aligned = vec("pad_world");
    f.strip_in_body = vec("strip_base");
    f.attitude = Eigen::Quaterniond(num("qw"), num("qx"), num("qy"), num("qz"));
    f.imu_attitude = Eigen::Quaterniond(num("imu_qw"), num("imu_qx"), num("imu_qy"), num("imu_qz"));
    f.tilt_deg = num("tilt_deg");
    f.sonar_range = num("sonar_range");
    f.sonar_range_before = num("sonar_range_before");
    f.sonar_range_after = num("sonar_range_after");
    f.sonar_field_of_view = num("sonar_field_of_view");
    f.baro_altitude = num("baro_altitude");
    f.baro_around = {num("baro_altitude_m2"), num("baro_altitude_m1"), num("baro_altitude_p1"), num("baro_altitude_p2")};
    f.visible_pad_share = num("visible_pad_share");
    f.visible_pad_corners = int(num("visible_pad_corners"));
    f.strip_corners_in_view = int(num("strip_corners_in_view"));
    f.marker_corners_in_view = int(num("marker_corners_in_view"));
    f.pad_shadow_share = num("pad_shadow_share");
    f.false_target_share = num("false_target_share");
    f.blur_px = num("blur_px");
    f.exposure_gain = num("exposure_gain");
    f.sun_elevation_deg = num("sun_elevation_deg");
    f.pixel_noise_std_omitted = num("pixel_noise_std_omitted");
    if (row.count("pad")) f.pad = text("pad");
    if (row.count("foreign_pad_share")) f.foreign_pad_share = num("foreign_pad_share");
    frames.push_back(f);
  }
  return frames;
}

FrameSensors sensorsAsTheNodeTakesThem(const RenderedFrame& f) {
  constexpr double kSonarPeriod = 0.04, kBaroPeriod = 0.05;  // 25 Hz and 20 Hz
  ReadingHistory sonar, baro;
  sonar.add(-kSonarPeriod, f.sonar_range_before);
  sonar.add(0.0, f.sonar_range);
  sonar.add(kSonarPeriod, f.sonar_range_after);
  const double offsets[5] = {-2 * kBaroPeriod, -kBaroPeriod, 0.0, kBaroPeriod, 2 * kBaroPeriod};
  const double values[5] = {f.baro_around[0], f.baro_around[1], f.baro_altitude, f.baro_around[2], f.baro_around[3]};
  for (int i = 0; i < 5; ++i) baro.add(offsets[i], values[i]);
  // The node's defaults (config/platform_detection.yaml timing/sonar_timeout, altimeter_window, altimeter_timeout).
  return {sonar.medianNear(0.0, 0.2), baro.meanNear(0.0, 0.1, 0.5), 0.5 * f.sonar_field_of_view};
}

cv::Mat loadRenderedImage(const std::string& dir, const RenderedFrame& frame, cv::RNG& rng) {
  const cv::Mat bgr = cv::imread(dir + "/" + frame.image, cv::IMREAD_COLOR);
  if (bgr.empty()) throw std::runtime_error("cannot read " + dir + "/" + frame.image);
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  if (rgb.cols != frame.intrinsics.width || rgb.rows != frame.intrinsics.height)
    throw std::runtime_error(dir + "/" + frame.image + " is not " + std::to_string(frame.intrinsics.width) + "x" +
                             std::to_string(frame.intrinsics.height) + " as truth.csv says");
  addSensorNoise(rgb, frame.pixel_noise_std_omitted, rng);
  return rgb;
}

void addSensorNoise(cv::Mat& image, double std, cv::RNG& rng) {
  if (!(std > 0.0)) return;
  cv::Mat noise(image.size(), CV_16SC(image.channels()));
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 255.0 * std);
  cv::add(image, noise, image, cv::noArray(), image.type());
}

}  // namespace uav_vision
