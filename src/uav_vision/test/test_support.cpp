#include "test_support.h"

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace uav_vision::test {

std::string testDataDir() { return UAV_VISION_TEST_DATA; }

std::vector<RenderedFixture> loadRenderedFixtures() {
  const std::string path = testDataDir() + "/rendered/truth.csv";
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::string line;
  std::getline(in, line);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  std::vector<std::string> header;
  {
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) header.push_back(cell);
  }
  std::vector<RenderedFixture> fixtures;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::map<std::string, std::string> row;
    std::stringstream s(line);
    size_t column = 0;
    for (std::string cell; std::getline(s, cell, ',') && column < header.size(); ++column) row[header[column]] = cell;
    auto num = [&](const std::string& key) {
      const auto it = row.find(key);
      if (it == row.end()) throw std::runtime_error(path + ": no column " + key);
      return std::stod(it->second);
    };
    auto vec = [&](const std::string& prefix) {
      return Eigen::Vector3d(num(prefix + "_x"), num(prefix + "_y"), num(prefix + "_z"));
    };
    RenderedFixture f;
    f.image = row["image"];
    f.band = row["band"];
    f.vehicle = row["vehicle"];
    f.height_landing_platform = num("height_landing_platform");
    f.camera_height = num("camera_height");
    f.intrinsics.fx = num("fx");
    f.intrinsics.fy = num("fy");
    f.intrinsics.cx = num("cx");
    f.intrinsics.cy = num("cy");
    f.intrinsics.width = 320;
    f.intrinsics.height = 240;
    f.pad_in_body = vec("pad_base");
    f.pad_world_aligned = vec("pad_world");
    f.strip_in_body = vec("strip_base");
    f.attitude = Eigen::Quaterniond(num("qw"), num("qx"), num("qy"), num("qz"));
    f.imu_attitude = Eigen::Quaterniond(num("imu_qw"), num("imu_qx"), num("imu_qy"), num("imu_qz"));
    f.tilt_deg = num("tilt_deg");
    f.sonar_range = num("sonar_range");
    f.baro_altitude = num("baro_altitude");
    f.visible_pad_share = num("visible_pad_share");
    f.visible_pad_corners = int(num("visible_pad_corners"));
    f.strip_corners_in_view = int(num("strip_corners_in_view"));
    f.marker_corners_in_view = int(num("marker_corners_in_view"));
    fixtures.push_back(f);
  }
  return fixtures;
}

cv::Mat loadImageRgb(const std::string& name) {
  const cv::Mat bgr = cv::imread(testDataDir() + "/rendered/" + name, cv::IMREAD_COLOR);
  if (bgr.empty()) throw std::runtime_error("cannot read " + name);
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

CameraIntrinsics simIntrinsics() {
  CameraIntrinsics k;
  k.fx = k.fy = 256.0;
  k.cx = 159.5;
  k.cy = 119.5;
  k.width = 320;
  k.height = 240;
  return k;
}

Eigen::Quaterniond attitudeFromRpy(double roll, double pitch, double yaw) {
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
}

void drawPlanePolygon(cv::Mat& image, const PlaneView& view, const std::vector<Eigen::Vector2d>& polygon,
                      const cv::Scalar& colour) {
  constexpr int kShift = 4;  // subpixel vertices
  std::vector<cv::Point> pixels;
  for (const auto& p : polygon) {
    const auto px = view.planeToPixel(p);
    if (!px) return;
    // OpenCV fills pixel centres at integer coordinates, like the pinhole model here.
    pixels.emplace_back(cvRound(px->x * (1 << kShift)), cvRound(px->y * (1 << kShift)));
  }
  cv::fillPoly(image, std::vector<std::vector<cv::Point>>{pixels}, colour, cv::LINE_8, kShift);
}

void drawPad(cv::Mat& image, const PlaneView& view, const Eigen::Vector2d& offset, double yaw, double side,
             bool with_strip, const cv::Scalar& red_bgr) {
  const Eigen::Vector2d forward(std::cos(yaw), std::sin(yaw)), left(-std::sin(yaw), std::cos(yaw));
  auto rectangle = [&](const Eigen::Vector2d& centre, double along, double across) {
    return std::vector<Eigen::Vector2d>{centre + along / 2 * forward + across / 2 * left,
                                        centre - along / 2 * forward + across / 2 * left,
                                        centre - along / 2 * forward - across / 2 * left,
                                        centre + along / 2 * forward - across / 2 * left};
  };
  drawPlanePolygon(image, view, rectangle(offset, side, side), red_bgr);
  if (with_strip) drawPlanePolygon(image, view, rectangle(offset + 0.36 * side * forward, 0.12 * side, 0.7 * side),
                                   cv::Scalar(38, 191, 26));
  drawPlanePolygon(image, view, rectangle(offset, 0.14 * side, 0.14 * side), kMarkerWhite);
}

cv::Mat groundImage(const CameraIntrinsics& intrinsics) {
  cv::Mat image(intrinsics.height, intrinsics.width, CV_8UC3, cv::Scalar(92, 87, 82));
  for (int y = 0; y < image.rows; y += 40)
    for (int x = (y / 40) % 2 * 40; x < image.cols; x += 80)
      cv::rectangle(image, cv::Rect(x, y, 40, 40), cv::Scalar(128, 138, 133), cv::FILLED);
  return image;
}

}  // namespace uav_vision::test
