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

std::string idealFixturesDir() { return testDataDir() + "/rendered"; }
std::string realisticFixturesDir() { return testDataDir() + "/rendered_realistic"; }

std::vector<RenderedFixture> loadRenderedFixtures() { return loadRenderedFrames(idealFixturesDir()); }

cv::Mat loadImageRgb(const std::string& name) {
  const cv::Mat bgr = cv::imread(idealFixturesDir() + "/" + name, cv::IMREAD_COLOR);
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
