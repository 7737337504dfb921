// Frames per second of the pad detector (and of the full localisation) on the rendered fixtures,
// 320x240, on one core.
//
//   rosrun uav_vision detector_benchmark [--dir DIR] [--seconds S]
//
// DIR defaults to the package's test/data/rendered (truth.csv + PNGs from test/render_fixtures.py).
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "uav_vision/pad_localizer.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Frame {
  std::string name;
  cv::Mat rgb;
  uav_vision::CameraIntrinsics intrinsics;
  Eigen::Quaterniond attitude;
  double camera_height, sonar, baro, platform_height;
};

std::vector<Frame> loadFrames(const std::string& dir) {
  std::ifstream in(dir + "/truth.csv");
  if (!in) {
    std::fprintf(stderr, "detector_benchmark: cannot open %s/truth.csv (make it with test/render_fixtures.py)\n",
                 dir.c_str());
    std::exit(2);
  }
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream hs(line);
  for (std::string cell; std::getline(hs, cell, ',');) header.push_back(cell);
  auto column = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end()) {
      std::fprintf(stderr, "detector_benchmark: truth.csv has no column %s\n", name.c_str());
      std::exit(2);
    }
    return size_t(it - header.begin());
  };
  std::vector<Frame> frames;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
    if (cells.size() != header.size()) continue;
    auto num = [&](const char* name) { return std::stod(cells[column(name)]); };
    Frame f;
    f.name = cells[column("image")];
    const cv::Mat bgr = cv::imread(dir + "/" + f.name, cv::IMREAD_COLOR);
    if (bgr.empty()) {
      std::fprintf(stderr, "detector_benchmark: cannot read %s\n", f.name.c_str());
      std::exit(2);
    }
    cv::cvtColor(bgr, f.rgb, cv::COLOR_BGR2RGB);
    f.intrinsics = {num("fx"), num("fy"), num("cx"), num("cy"), bgr.cols, bgr.rows};
    f.attitude = Eigen::Quaterniond(num("imu_qw"), num("imu_qx"), num("imu_qy"), num("imu_qz"));
    f.camera_height = num("camera_height");
    f.sonar = num("sonar_range");
    f.baro = num("baro_altitude");
    f.platform_height = num("height_landing_platform");
    frames.push_back(f);
  }
  return frames;
}

// CPU time of this thread [us]: what the detector costs on one core, whatever else the machine runs.
double threadCpuMicros() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e6 + t.tv_nsec * 1e-3;
}

struct Timing {
  std::vector<double> cpu_us;  // per frame
  double wall_us = 0.0;        // whole run
};

// Runs `work` over all frames repeatedly for about `seconds` of wall time.
template <typename Work>
Timing timeFrames(const std::vector<Frame>& frames, double seconds, Work work) {
  Timing timing;
  for (const auto& f : frames) work(f);  // warm-up: buffers allocated, caches filled
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  while (Clock::now() < end)
    for (const auto& f : frames) {
      const double t0 = threadCpuMicros();
      work(f);
      timing.cpu_us.push_back(threadCpuMicros() - t0);
    }
  timing.wall_us = std::chrono::duration<double, std::micro>(Clock::now() - start).count();
  return timing;
}

void report(const char* what, Timing timing) {
  auto& t = timing.cpu_us;
  std::sort(t.begin(), t.end());
  double total = 0.0;
  for (double x : t) total += x;
  const double mean = total / t.size();
  std::printf("%-44s %6.0f frames/s on one core (CPU time: mean %5.0f us, median %5.0f us, p99 %5.0f us); "
              "wall clock %6.0f frames/s; %zu frames\n",
              what, 1e6 / mean, mean, t[t.size() / 2], t[t.size() * 99 / 100], t.size() / (timing.wall_us * 1e-6),
              t.size());
}

}  // namespace

int main(int argc, char** argv) {
  std::string dir = UAV_VISION_DEFAULT_FIXTURES;
  double seconds = 3.0;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--dir" && i + 1 < argc) {
      dir = argv[++i];
    } else if (arg == "--seconds" && i + 1 < argc) {
      seconds = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: detector_benchmark [--dir DIR] [--seconds S]\n");
      return 2;
    }
  }
  cv::setNumThreads(1);  // one core, as on the drone next to the rest of the graph
  const std::vector<Frame> frames = loadFrames(dir);
  if (frames.empty()) {
    std::fprintf(stderr, "detector_benchmark: no frames in %s\n", dir.c_str());
    return 2;
  }
  std::printf("detector_benchmark: %zu rendered frames %dx%d from %s, OpenCV %s, 1 thread\n", frames.size(),
              frames[0].rgb.cols, frames[0].rgb.rows, dir.c_str(), CV_VERSION);

  const uav_vision::CameraMount mount = uav_vision::CameraMount::bottomCamera(0.035);
  uav_vision::PadLocalizerParams params;
  std::vector<uav_vision::PadLocalizer> localizers;
  for (const auto& f : frames) {
    params.height.height_landing_platform = f.platform_height;
    localizers.emplace_back(params, mount);
  }
  const uav_vision::PadDetector detector(params.detector);
  int found = 0;
  report("detect(), camera geometry known", timeFrames(frames, seconds, [&](const Frame& f) {
           const uav_vision::PlaneView view(f.intrinsics, mount, f.attitude, f.camera_height);
           found += detector.detect(f.rgb, uav_vision::ColorOrder::kRgb, &view).found;
         }));
  report("observe(): sonar + barometer + IMU + image", timeFrames(frames, seconds, [&](const Frame& f) {
           const auto& localizer = localizers[&f - frames.data()];
           localizer.observe(f.rgb, uav_vision::ColorOrder::kRgb, f.intrinsics, f.attitude, f.sonar, f.baro);
         }));
  cv::Mat hsv;
  report("  of which cv::cvtColor RGB->HSV alone", timeFrames(frames, seconds, [&](const Frame& f) {
           cv::cvtColor(f.rgb, hsv, cv::COLOR_RGB2HSV);
         }));
  std::printf("target: >= 1000 frames/s\n");
  return found > 0 ? 0 : 1;
}
