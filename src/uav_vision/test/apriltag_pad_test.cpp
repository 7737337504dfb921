// AprilTagPadDetector and the localizer with the AprilTag pad, on synthesised frames: the pad's top view (the
// texture the simulator uses) painted through the camera model at known places, from 6 m down to 0.3 m, rotated,
// tilted, through a distorted lens, beside a foreign pad (the same families, other ids), a copy of the inner tag
// and the red pad; and the checks of the parameters.
#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "test_support.h"
#include "uav_vision/apriltag_pad_detector.h"
#include "uav_vision/pad_localizer.h"

namespace uav_vision::test {
namespace {

constexpr double kDeg = M_PI / 180.0;
const CameraMount kMount = CameraMount::bottomCamera(0.035);

struct PadOnPlane {
  cv::Mat top;                        // top view, grey (up = forward)
  double width;                       // its side [m]
  Eigen::Vector2d offset;             // centre from the camera, world-aligned [m]
  double yaw;                         // forward axis in the world [rad]
};

// Paints the pads lying on the plane of `view` over `image` (BGR), 2x2 samples per pixel; with `lens`, the image is
// the distorted camera's (each pixel's ideal position from the lens table).
void paint(cv::Mat& image, const PlaneView& view, const std::vector<PadOnPlane>& pads,
           const LensUndistortion* lens = nullptr) {
  constexpr int kSamples = 2;
  constexpr double kBlack = 35.0, kWhite = 205.0;
  const cv::Mat ground = image.clone();
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const cv::Point2d base = lens ? cv::Point2d(lens->undistort({x, y})) : cv::Point2d(x, y);
      double sum = 0.0;
      int on_pad = 0;
      for (int i = 0; i < kSamples; ++i) {
        for (int j = 0; j < kSamples; ++j) {
          const cv::Point2d px = base + cv::Point2d((i + 0.5) / kSamples - 0.5, (j + 0.5) / kSamples - 0.5);
          const auto plane = view.pixelToPlane(px);
          if (!plane) continue;
          for (const PadOnPlane& pad : pads) {
            const Eigen::Vector2d rel = *plane - pad.offset;
            const double forward = rel.x() * std::cos(pad.yaw) + rel.y() * std::sin(pad.yaw);
            const double left = -rel.x() * std::sin(pad.yaw) + rel.y() * std::cos(pad.yaw);
            if (std::abs(forward) >= pad.width / 2 || std::abs(left) >= pad.width / 2) continue;
            const int n = pad.top.cols;
            const int col = std::clamp(int((0.5 - left / pad.width) * n), 0, n - 1);
            const int row = std::clamp(int((0.5 - forward / pad.width) * n), 0, n - 1);
            sum += pad.top.at<uint8_t>(row, col) ? kWhite : kBlack;
            ++on_pad;
            break;
          }
        }
      }
      if (on_pad == 0) continue;
      const cv::Vec3b g = ground.at<cv::Vec3b>(y, x);
      const int n = kSamples * kSamples;
      for (int c = 0; c < 3; ++c)
        image.at<cv::Vec3b>(y, x)[c] = cv::saturate_cast<uint8_t>((sum + g[c] * (n - on_pad)) / n);
    }
  }
}

const cv::Mat& padTop() {
  static const cv::Mat top = AprilTagPadDetector::topView(AprilTagPadLayout(), 400);
  return top;
}

// The same families and sizes, other ids: another pad of the same kind.
AprilTagPadLayout foreignLayout() {
  AprilTagPadLayout layout;
  layout.outer.id = 6;
  layout.inner.id = 8;
  return layout;
}

struct Scene {
  PlaneView view;
  cv::Mat image;  // BGR
  Eigen::Vector2d offset;
  double yaw;
};

Scene makeScene(double height, const Eigen::Vector2d& offset, double yaw,
                const Eigen::Quaterniond& attitude = Eigen::Quaterniond::Identity(),
                const CameraIntrinsics& intrinsics = simIntrinsics()) {
  Scene s{PlaneView(intrinsics, kMount, attitude, height), groundImage(intrinsics), offset, yaw};
  std::unique_ptr<LensUndistortion> lens;
  if (intrinsics.distorted()) lens = std::make_unique<LensUndistortion>(intrinsics);
  paint(s.image, s.view, {{padTop(), 1.0, offset, yaw}}, lens.get());
  return s;
}

PadLocalizer apriltagLocalizer(const AprilTagPadParams& params = AprilTagPadParams()) {
  PadLocalizerParams p;
  p.pad = PadKind::kAprilTag;
  p.apriltag = params;
  return PadLocalizer(p, kMount);
}

double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// ---------------------------------------------------------------------------------------------------------------

TEST(AprilTagPadLayout, TheShippedLayoutFillsTheMetrePadWithTheSmallTagInTheHole) {
  const AprilTagPadLayout layout;
  EXPECT_NEAR(AprilTagPadDetector::fullWidth(layout.outer), 1.0, 1e-12);
  EXPECT_NEAR(AprilTagPadDetector::holeWidth(layout.outer), 0.2, 1e-12);
  EXPECT_NEAR(AprilTagPadDetector::fullWidth(layout.inner), 0.2, 1e-12);
  EXPECT_EQ(AprilTagPadDetector::validate(AprilTagPadParams()), "");
  const cv::Mat& top = padTop();
  ASSERT_EQ(top.rows, 400);
  // The inner tag36h11's white ring around its black border, at the centre.
  EXPECT_EQ(top.at<uint8_t>(162, 200), 255);
  EXPECT_EQ(top.at<uint8_t>(170, 200), 0);
  // Corners in libapriltag's order: tag (-1, 1) is the tag image's bottom left: behind and to the left.
  const auto corners = AprilTagPadDetector::tagCornersOnPad(layout.outer);
  EXPECT_NEAR(corners[0].x, -0.3, 1e-12);
  EXPECT_NEAR(corners[0].y, 0.3, 1e-12);
  EXPECT_NEAR(corners[2].x, 0.3, 1e-12);
  EXPECT_NEAR(corners[2].y, -0.3, 1e-12);
}

TEST(AprilTagPadParams, BadValuesAreRefusedNamingTheKeyAndTheChoices) {
  AprilTagPadParams p;
  p.layout.outer.family = "tag99h1";
  std::string problem = AprilTagPadDetector::validate(p);
  EXPECT_NE(problem.find("apriltag/outer/family"), std::string::npos) << problem;
  EXPECT_NE(problem.find("tagCustom48h12"), std::string::npos) << problem;  // lists the families built for
  EXPECT_THROW(AprilTagPadDetector{p}, std::invalid_argument);

  p = AprilTagPadParams();
  p.layout.inner.size = 0.0;  // a missing size
  problem = AprilTagPadDetector::validate(p);
  EXPECT_NE(problem.find("apriltag/inner/size"), std::string::npos) << problem;

  p = AprilTagPadParams();
  p.layout.inner.size = 0.2;  // 0.25 m with its ring: not in the 0.2 m hole
  problem = AprilTagPadDetector::validate(p);
  EXPECT_NE(problem.find("at most 0.160 m"), std::string::npos) << problem;

  p = AprilTagPadParams();
  p.layout.outer = {"tag36h11", 1, 0.8};  // no hole
  problem = AprilTagPadDetector::validate(p);
  EXPECT_NE(problem.find("no hole"), std::string::npos) << problem;

  p = AprilTagPadParams();
  p.layout.inner.id = 587;  // tag36h11 has 587 codes
  problem = AprilTagPadDetector::validate(p);
  EXPECT_NE(problem.find("ids 0..586"), std::string::npos) << problem;

  p = AprilTagPadParams();
  p.layout.inner = p.layout.outer;
  p.layout.inner.size = 0.1;
  problem = AprilTagPadDetector::validate(p);
  EXPECT_NE(problem.find("the same tag"), std::string::npos) << problem;

  p = AprilTagPadParams();
  p.max_hamming = 4;
  EXPECT_NE(AprilTagPadDetector::validate(p).find("max_hamming"), std::string::npos);
  p = AprilTagPadParams();
  p.quad_decimate = 0.5;
  EXPECT_NE(AprilTagPadDetector::validate(p).find("quad_decimate"), std::string::npos);

  PadLocalizerParams lp;
  lp.pad = PadKind::kAprilTag;
  lp.apriltag.layout.outer.family = "nope";
  EXPECT_THROW(PadLocalizer(lp, kMount), std::invalid_argument);
  EXPECT_EQ(padKindFromString("apriltag"), PadKind::kAprilTag);
  EXPECT_EQ(padKindFromString("red_square"), PadKind::kRedSquare);
  EXPECT_FALSE(padKindFromString("Apriltag"));
}

// From 6 m down to 0.3 m, level and tilted: the centre where it is, the heading, and the pose from the tags.
TEST(AprilTagPadDetector, FoundFromSixMetresDownToThirtyCentimetres) {
  const PadLocalizer localizer = apriltagLocalizer();
  struct Case {
    double height, x, y, yaw, roll, pitch;
    bool inner_only;
  };
  const Case cases[] = {
      {6.0, 0.5, -0.8, 20 * kDeg, 0.0, 0.0, false}, {6.0, -1.5, 1.0, -120 * kDeg, 5 * kDeg, -8 * kDeg, false},
      {4.0, 0.3, 0.4, 75 * kDeg, 0.0, 10 * kDeg, false}, {2.5, -0.4, -0.3, 170 * kDeg, -6 * kDeg, 0.0, false},
      {1.5, 0.05, 0.1, -40 * kDeg, 0.0, 0.0, false},    {0.9, 0.02, -0.03, 10 * kDeg, 3 * kDeg, 0.0, true},
      {0.5, -0.03, 0.05, 100 * kDeg, 0.0, 0.0, true},    {0.3, 0.02, 0.01, -160 * kDeg, 2 * kDeg, -2 * kDeg, true},
  };
  for (const Case& c : cases) {
    const Eigen::Quaterniond attitude = attitudeFromRpy(c.roll, c.pitch, 0.3);
    const Scene s = makeScene(c.height, {c.x, c.y}, c.yaw, attitude);
    const PadObservation o = localizer.observeAtHeight(s.image, ColorOrder::kBgr, simIntrinsics(), attitude, c.height);
    SCOPED_TRACE("height " + std::to_string(c.height));
    ASSERT_TRUE(o.found) << o.reason;
    EXPECT_EQ(o.detection.marker, c.inner_only);
    const Eigen::Vector3d truth = s.view.fromBaseInBody(s.offset);
    EXPECT_LT((o.centre_in_body - truth).head<2>().norm(), 0.004 + 0.002 * c.height);
    ASSERT_TRUE(o.strip_found);
    EXPECT_LT(std::abs(wrap(o.pad_yaw - c.yaw)), 1.5 * kDeg);
    // The tags' pose alone (their sizes and K): the same centre, a little less sure of the depth.
    ASSERT_TRUE(o.tag_pose_found);
    EXPECT_LT((o.tag_centre_in_body - truth).norm(), 0.01 + 0.01 * c.height);
  }
}

TEST(AprilTagPadDetector, ThroughADistortedLens) {
  CameraIntrinsics k = simIntrinsics();
  k.distortion = {-0.2, 0.04, 0.001, -0.001, 0.0};  // the realistic profile's lens
  const PadLocalizer localizer = apriltagLocalizer();
  for (const auto& [height, x, y] : {std::tuple{3.0, 1.0, 0.8}, std::tuple{1.3, 0.15, -0.1}, std::tuple{0.4, 0.02, 0.03}}) {
    const Scene s = makeScene(height, {x, y}, 0.7, Eigen::Quaterniond::Identity(), k);
    const PadObservation o = localizer.observeAtHeight(s.image, ColorOrder::kBgr, k, Eigen::Quaterniond::Identity(), height);
    ASSERT_TRUE(o.found) << height << ": " << o.reason << " (" << localizer.apriltagDetector()->lastTags().size() << " tags)";
    EXPECT_LT((o.centre_in_body - s.view.fromBaseInBody(s.offset)).head<2>().norm(), 0.01) << height;
  }
}

TEST(AprilTagPadDetector, AForeignPadAndTheRedPadAreNotThePad) {
  const AprilTagPadDetector detector;
  const PlaneView view(simIntrinsics(), kMount, Eigen::Quaterniond::Identity(), 3.0);
  // A pad of the same kind with other ids, alone.
  cv::Mat image = groundImage(simIntrinsics());
  paint(image, view, {{AprilTagPadDetector::topView(foreignLayout(), 400), 1.0, {0.2, 0.1}, 0.3}});
  Detection d = detector.detect(image, ColorOrder::kBgr, &view);
  EXPECT_FALSE(d.found);
  EXPECT_TRUE(detector.lastTags().empty());  // its codes are not in the detector's dictionary
  // A single tag36h11 of another id, large.
  AprilTagPadLayout single;
  single.outer = {"tagCustom48h12", 9, 0.6};
  single.inner = {"tag36h11", 3, 0.16};
  image = groundImage(simIntrinsics());
  paint(image, view, {{AprilTagPadDetector::topView(single, 400), 1.0, {-0.3, 0.2}, -1.0}});
  EXPECT_FALSE(detector.detect(image, ColorOrder::kBgr, &view).found);
  // The red pad.
  image = groundImage(simIntrinsics());
  drawPad(image, view, {0.1, 0.2}, 0.4);
  d = detector.detect(image, ColorOrder::kBgr, &view);
  EXPECT_FALSE(d.found);
  EXPECT_EQ(d.reason, "no tag of the pad in view");
  // The pad beside the foreign one: the pad, where it is.
  image = groundImage(simIntrinsics());
  paint(image, view, {{padTop(), 1.0, {0.7, 0.0}, 0.0}, {AprilTagPadDetector::topView(foreignLayout(), 400), 1.0,
                                                         {-0.7, 0.0}, 0.0}});
  d = detector.detect(image, ColorOrder::kBgr, &view);
  ASSERT_TRUE(d.found) << d.reason;
  EXPECT_LT((*view.pixelToPlane(d.centre_px) - Eigen::Vector2d(0.7, 0.0)).norm(), 0.01);
}

TEST(AprilTagPadDetector, AWrongHeightOrAMisplacedCopyOfTheInnerTagIsRejected) {
  const AprilTagPadDetector detector;
  const Scene s = makeScene(3.0, {0.2, -0.1}, 0.5);
  // The sonar's echo from the ground, 0.5 m below the pad: the tag measures 17 % too large.
  const PlaneView wrong(simIntrinsics(), kMount, Eigen::Quaterniond::Identity(), 3.5);
  Detection d = detector.detect(s.image, ColorOrder::kBgr, &wrong);
  EXPECT_FALSE(d.found);
  EXPECT_NE(d.reason.find("measures"), std::string::npos) << d.reason;
  EXPECT_TRUE(detector.detect(s.image, ColorOrder::kBgr, &s.view).found);

  // The pad at 1.5 m, and a second print of its inner tag (the same id and size) lying 0.8 m away.
  const PlaneView view(simIntrinsics(), kMount, Eigen::Quaterniond::Identity(), 1.5);
  cv::Mat image = groundImage(simIntrinsics());
  const cv::Mat inner_only = padTop()(cv::Rect(160, 160, 80, 80)).clone();
  paint(image, view, {{padTop(), 1.0, {0.1, 0.0}, 0.0}, {inner_only, 0.2, {0.1, 0.8}, 0.0}});
  d = detector.detect(image, ColorOrder::kBgr, &view);
  ASSERT_TRUE(d.found) << d.reason;
  EXPECT_LT((*view.pixelToPlane(d.centre_px) - Eigen::Vector2d(0.1, 0.0)).norm(), 0.01);
  int rejected = 0;
  for (const TagSighting& t : detector.lastTags()) rejected += !t.accepted;
  EXPECT_EQ(rejected, 1);
}

TEST(AprilTagPadDetector, WithoutTheViewTheCentreAndThePoseStillCome) {
  const AprilTagPadDetector detector;
  const Scene s = makeScene(2.0, {0.3, 0.2}, -0.6);
  const Detection d = detector.detect(s.image, ColorOrder::kBgr, simIntrinsics());
  ASSERT_TRUE(d.found) << d.reason;
  const cv::Point2d truth = *s.view.planeToPixel(s.offset);
  EXPECT_LT(cv::norm(d.centre_px - truth), 0.5);
  ASSERT_TRUE(d.pose_found);
  EXPECT_NEAR(d.pad_in_camera[2], 2.0, 0.03);  // the depth from the tags' size
  cv::Mat grey;
  cv::cvtColor(s.image, grey, cv::COLOR_BGR2GRAY);
  EXPECT_TRUE(detector.detect(grey, ColorOrder::kBgr, simIntrinsics()).found);
  EXPECT_FALSE(detector.detect(cv::Mat(), ColorOrder::kBgr).found);
  EXPECT_FALSE(detector.detect(cv::Mat(240, 320, CV_16UC3, cv::Scalar(0)), ColorOrder::kBgr).found);
}

}  // namespace
}  // namespace uav_vision::test
