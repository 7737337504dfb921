// Unit tests of DelayedFusion (measurements that arrive late and out of order) and of the GPS offset
// the filter learns while vision holds the track. Synthetic Summit XL trajectories with seeded noise.
#include "ped_traj_pred/delayed_fusion.h"
#include "ped_traj_pred/synthetic_trajectory.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace ped_traj_pred
{
namespace
{
constexpr double kCameraRate = 30.0;  // [Hz]
constexpr double kGpsRate = 5.0;      // [Hz]

/// One measurement as it is sent: taken at `stamp`, received at `arrival`.
struct Sent
{
  double stamp, arrival;
  bool vision;
  Eigen::Vector3d position;
  VehicleReport report;
};

/// Vision fixes (1 cm noise) and vehicle reports (GPS `gps_offset` + 0.3 m noise, velocity 0.1 m/s, heading
/// 2 deg) of `trajectory` while vision lasts (`vision_until`), with arrival delays `vision_delay` +-
/// `jitter` and `gps_delay`, in the order they arrive.
std::vector<Sent> measurements(const SyntheticTrajectory& trajectory, unsigned seed, double vision_delay,
                               double jitter, double gps_delay, const Eigen::Vector2d& gps_offset = Eigen::Vector2d::Zero(),
                               double vision_until = 1e9)
{
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Sent> sent;
  const int gps_every = static_cast<int>(std::lround(kCameraRate / kGpsRate));
  for (int k = 0; k < trajectory.size(); ++k)
  {
    const double t = trajectory.sampleTime(k);
    if (t <= vision_until)
    {
      const Eigen::Vector3d noise(0.01 * normal(rng), 0.01 * normal(rng), 0.01 * normal(rng));
      const double delay = std::max(0.0, vision_delay + jitter * normal(rng));
      sent.push_back({ t, t + delay, true, trajectory.position(k) + noise, {} });
    }
    if (k % gps_every == 0)
    {
      VehicleReport report;
      report.pad_position =
          Eigen::Vector2d(trajectory.position(k).head<2>() + gps_offset + 0.3 * Eigen::Vector2d(normal(rng), normal(rng)));
      report.velocity = trajectory.velocity(k) + 0.1 * Eigen::Vector2d(normal(rng), normal(rng));
      report.velocity_variance = 0.01;
      report.heading = trajectory.heading(k) + 0.035 * normal(rng);
      report.heading_variance = 0.035 * 0.035;
      report.yaw_rate = std::nullopt;
      sent.push_back({ t, t + gps_delay, false, Eigen::Vector3d::Zero(), report });
    }
  }
  std::stable_sort(sent.begin(), sent.end(), [](const Sent& a, const Sent& b) { return a.arrival < b.arrival; });
  return sent;
}

void feed(DelayedFusion& fusion, const Sent& m)
{
  if (m.vision)
    fusion.addVision(m.stamp, m.position, 1e-4);
  else
    fusion.addVehicleReport(m.stamp, m.report);
}

TrajectorySpec squarePath()
{
  TrajectorySpec spec;
  spec.kind = PathKind::kStopAndGo;
  spec.speed = 3.0;
  spec.max_acceleration = 1.0;
  spec.duration = 20.0;
  return spec;
}

TEST(DelayedFusion, LateAndReorderedMeasurementsGiveTheSameTrackAsTimelyOnes)
{
  const SyntheticTrajectory trajectory(squarePath(), kCameraRate);
  const std::vector<Sent> timely = measurements(trajectory, 3, 0.0, 0.0, 0.0);
  // The same draws: the seed fixes the noise; only the arrival order differs.
  const std::vector<Sent> late = measurements(trajectory, 3, 0.1, 0.02, 0.25);
  DelayedFusion in_order({}, 1.0), reordered({}, 1.0);
  for (const Sent& m : timely)
    feed(in_order, m);
  for (const Sent& m : late)
    feed(reordered, m);
  EXPECT_GT(reordered.replayed(), 100);
  const double end = trajectory.sampleTime(trajectory.size() - 1);
  const auto a = in_order.stateAt(end), b = reordered.stateAt(end);
  ASSERT_TRUE(a && b);
  EXPECT_LT((a->position - b->position).norm(), 1e-6);
  EXPECT_LT((a->velocity - b->velocity).norm(), 1e-6);
}

TEST(DelayedFusion, NoFixIsLostToItsLateness)
{
  // Frames whose Wi-Fi delay jitters arrive out of order, and the vehicle's reports 0.25 s late: a plain
  // filter fed in arrival order drops every one older than its state. (The vehicle's speed, heading and
  // yaw rate it still takes up to 0.5 s late, applied to its present state: about as good, 0.22 m/s RMS
  // either way after the speed changes of this path. What it loses are the fixes.)
  const SyntheticTrajectory trajectory(squarePath(), kCameraRate);
  const std::vector<Sent> late = measurements(trajectory, 5, 0.1, 0.03, 0.25);
  DelayedFusion fusion({}, 1.0);
  PadMotionFilter plain({});
  int plain_stale_frames = 0, fusion_stale = 0;
  for (const Sent& m : late)
  {
    const MeasurementOutcome outcome =
        m.vision ? fusion.addVision(m.stamp, m.position, 1e-4) : fusion.addVehicleReport(m.stamp, m.report);
    fusion_stale += outcome == MeasurementOutcome::kDroppedStale;
    if (m.vision)
      plain_stale_frames += plain.addVision(m.stamp, m.position, 1e-4) == MeasurementOutcome::kDroppedStale;
  }
  std::printf("[ stats    ] frames 0.1 +- 0.03 s late: %d of %d dropped as stale in arrival order, %d with delayed "
              "fusion\n", plain_stale_frames, trajectory.size(), fusion_stale);
  EXPECT_GT(plain_stale_frames, trajectory.size() / 20);
  EXPECT_EQ(fusion_stale, 0);
}

TEST(DelayedFusion, MeasurementsOlderThanTheHorizonAreDroppedAsStale)
{
  DelayedFusion fusion({}, 0.5);
  EXPECT_EQ(fusion.addVision(1.0, Eigen::Vector3d(0, 0, 0.5), 1e-4), MeasurementOutcome::kInitialised);
  EXPECT_EQ(fusion.addVision(2.0, Eigen::Vector3d(0, 0, 0.5), 1e-4), MeasurementOutcome::kAccepted);
  EXPECT_EQ(fusion.addVision(1.2, Eigen::Vector3d(0, 0, 0.5), 1e-4), MeasurementOutcome::kDroppedStale);
  EXPECT_EQ(fusion.addVision(1.8, Eigen::Vector3d(0, 0, 0.5), 1e-4), MeasurementOutcome::kAccepted);
  EXPECT_EQ(fusion.addVision(std::nan(""), Eigen::Vector3d(0, 0, 0.5), 1e-4), MeasurementOutcome::kDroppedInvalid);
  EXPECT_THROW(DelayedFusion({}, 0.0), std::invalid_argument);
}

TEST(GpsOffset, LearntWhileVisionHoldsTheTrackAndTakenOffWhenOnlyGpsIsLeft)
{
  // The vehicle's GPS is 1.2 m off (its receiver's drifting error); vision stops after 15 s. Without the
  // offset the track would jump to the GPS and put the pad 1.2 m away from where the camera will find it.
  TrajectorySpec spec;
  spec.kind = PathKind::kCircle;
  spec.speed = 2.0;
  spec.duration = 22.0;
  const SyntheticTrajectory trajectory(spec, kCameraRate);
  const Eigen::Vector2d offset(1.0, -0.66);
  const std::vector<Sent> sent = measurements(trajectory, 7, 0.1, 0.0, 0.2, offset, 15.0);
  FilterParameters learning, not_learning;
  not_learning.gps_offset_initial_std = 0.0;
  not_learning.gps_offset_drift = 0.0;
  DelayedFusion with(learning, 1.0), without(not_learning, 1.0);
  double worst_with = 0.0, worst_without = 0.0;
  for (const Sent& m : sent)
  {
    feed(with, m);
    feed(without, m);
    if (m.arrival > 17.0)  // GPS alone for 2 s
    {
      const int k = std::min(trajectory.size() - 1, static_cast<int>(std::lround(m.arrival * kCameraRate)));
      const Eigen::Vector2d truth = trajectory.position(k).head<2>();
      worst_with = std::max(worst_with, (with.stateAt(m.arrival)->position.head<2>() - truth).norm());
      worst_without = std::max(worst_without, (without.stateAt(m.arrival)->position.head<2>() - truth).norm());
    }
  }
  EXPECT_LT((with.filter().gpsOffset() - offset).norm(), 0.35);
  EXPECT_LT(worst_with, 0.5);
  EXPECT_GT(worst_without, 0.9);
}

TEST(GpsOffset, ATrackThatGpsStartedTakesTheCameraFixesThatDisagree)
{
  // On the pad before take-off the camera sees nothing and the vehicle's GPS starts the track, 1.2 m off.
  // Fused as independent noise, thirty fixes would have made the track sure of itself to 5 cm, and the
  // camera's first fixes outliers until ten in a row restart it.
  TrajectorySpec spec;
  spec.kind = PathKind::kStraight;
  spec.speed = 2.0;
  spec.duration = 10.0;
  const SyntheticTrajectory trajectory(spec, kCameraRate);
  const std::vector<Sent> gps_only = measurements(trajectory, 9, 0.1, 0.0, 0.2, Eigen::Vector2d(1.2, 0.0), -1.0);
  DelayedFusion fusion({}, 1.0);
  int rejected = 0;
  for (const Sent& m : gps_only)
  {
    if (m.stamp < 6.0)
    {
      if (!m.vision)
        fusion.addVehicleReport(m.stamp, m.report);
      continue;
    }
    const int k = std::min(trajectory.size() - 1, static_cast<int>(std::lround(m.stamp * kCameraRate)));
    const MeasurementOutcome outcome = fusion.addVision(m.stamp, trajectory.position(k), 1e-4);
    rejected += outcome == MeasurementOutcome::kRejected || outcome == MeasurementOutcome::kReinitialised;
  }
  EXPECT_EQ(rejected, 0);
}

}  // namespace
}  // namespace ped_traj_pred

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
