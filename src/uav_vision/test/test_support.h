// Helpers shared by the detector tests: rendered fixtures and synthetic scenes.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "uav_vision/camera_geometry.h"
#include "uav_vision/pad_detector.h"
#include "uav_vision/rendered_frames.h"

namespace uav_vision::test {

// test/data/rendered (the ideal fixtures) and test/data/rendered_realistic, both made by
// src/landing_bench/test/render_fixtures.py (the simulator renders them there, in landing_bench: these tests only
// read the committed files).
using RenderedFixture = RenderedFrame;
std::string testDataDir();
std::string idealFixturesDir();
std::string realisticFixturesDir();
std::vector<RenderedFixture> loadRenderedFixtures();  // the ideal set
cv::Mat loadImageRgb(const std::string& name);        // from the ideal set, RGB order

// The simulator's bottom camera intrinsics (320x240, fx = fy = 256).
CameraIntrinsics simIntrinsics();

Eigen::Quaterniond attitudeFromRpy(double roll, double pitch, double yaw);

// Draws a pad (red square with its green strip) lying on the plane seen by `view`: centre at `offset`
// from the camera (world-aligned), forward axis at `yaw` in the world; colours in BGR.
// The white centre marker as the simulator renders it (grey-white under its light), BGR.
const cv::Scalar kMarkerWhite(180, 180, 180);
// The pad as the simulator's: red square, green heading strip (optional), white centre marker.
void drawPad(cv::Mat& image, const PlaneView& view, const Eigen::Vector2d& offset, double yaw,
             double side = 1.0, bool with_strip = true, const cv::Scalar& red_bgr = cv::Scalar(38, 38, 217));
// A filled polygon given on the plane.
void drawPlanePolygon(cv::Mat& image, const PlaneView& view, const std::vector<Eigen::Vector2d>& polygon,
                      const cv::Scalar& colour);
// Grey checkered ground as in the simulator, BGR.
cv::Mat groundImage(const CameraIntrinsics& intrinsics);

}  // namespace uav_vision::test
