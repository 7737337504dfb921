// The AprilTag pad seen from above, as a PNG (the vehicle's front up, the pad's right to the right), from
// libapriltag's family bitmaps: the texture mujoco_sim puts on the pad.
//
//   rosrun uav_vision apriltag_pad_texture --out FILE [--pixels N] [--outer FAMILY ID SIZE] [--inner FAMILY ID SIZE]
//
// Defaults: the shipped layout of config/platform_detection.yaml (apriltag/outer, apriltag/inner). The shipped
// textures were made with
//   apriltag_pad_texture --out src/mujoco_sim/models/apriltag_pad.png
//   apriltag_pad_texture --out src/mujoco_sim/models/apriltag_foreign_pad.png --outer tagCustom48h12 6 0.6 \
//       --inner tag36h11 8 0.16
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "uav_vision/apriltag_pad_detector.h"

namespace {

int usage() {
  std::fprintf(stderr,
               "usage: apriltag_pad_texture --out FILE [--pixels N] [--outer FAMILY ID SIZE] [--inner FAMILY ID SIZE]\n"
               "  SIZE: the tag's detection square [m]; families: ");
  for (const auto& name : uav_vision::apriltagFamilies()) std::fprintf(stderr, "%s ", name.c_str());
  std::fprintf(stderr, "\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  uav_vision::AprilTagPadLayout layout;
  std::string out;
  int pixels = 400;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else if (arg == "--pixels" && i + 1 < argc) {
      pixels = std::atoi(argv[++i]);
    } else if ((arg == "--outer" || arg == "--inner") && i + 3 < argc) {
      uav_vision::TagSpec& tag = arg == "--outer" ? layout.outer : layout.inner;
      tag.family = argv[++i];
      tag.id = std::atoi(argv[++i]);
      tag.size = std::atof(argv[++i]);
    } else {
      return usage();
    }
  }
  if (out.empty()) return usage();
  try {
    const cv::Mat view = uav_vision::AprilTagPadDetector::topView(layout, pixels);
    if (!cv::imwrite(out, view, {cv::IMWRITE_PNG_COMPRESSION, 9})) {
      std::fprintf(stderr, "apriltag_pad_texture: cannot write %s\n", out.c_str());
      return 1;
    }
    std::printf("%s: %dx%d px, %.3f m square: outer %s id %d (%.3f m), inner %s id %d (%.3f m)\n", out.c_str(), pixels,
                pixels, uav_vision::AprilTagPadDetector::fullWidth(layout.outer), layout.outer.family.c_str(),
                layout.outer.id, layout.outer.size, layout.inner.family.c_str(), layout.inner.id, layout.inner.size);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "apriltag_pad_texture: %s\n", e.what());
    return 2;
  }
  return 0;
}
