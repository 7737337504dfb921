// config/kalman.yaml, which the node loads, equals the filter's defaults in pad_motion_filter.h, which the
// gtests and kalman_benchmark use: tuning one without the other would leave the benchmark measuring a
// filter the node does not run. (platform_tracking's Python tests check its YAML files the same way.)
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <map>
#include <set>
#include <string>

#include "ped_traj_pred/pad_motion_filter.h"

namespace
{
using ped_traj_pred::FilterParameters;

std::map<std::string, double> filterDefaults()
{
  const FilterParameters p;
  return {
    { "model_covariance", p.model_covariance },
    { "turn_rate_covariance", p.turn_rate_covariance },
    { "velocity_covariance", p.velocity_covariance },
    { "height_covariance", p.height_covariance },
    { "manoeuvre_covariance_scale", p.manoeuvre_covariance_scale },
    { "manoeuvre_acceleration_covariance", p.manoeuvre_acceleration_covariance },
    { "steady_mode_duration", p.steady_mode_duration },
    { "manoeuvre_mode_duration", p.manoeuvre_mode_duration },
    { "onset_window", p.onset_window },
    { "onset_acceleration_std", p.onset_acceleration_std },
    { "onset_threshold", p.onset_threshold },
    { "stop_threshold", p.stop_threshold },
    { "observation_covariance", p.observation_covariance },
    { "observation_std_floor", p.observation_std_floor },
    { "observation_std_per_metre", p.observation_std_per_metre },
    { "gps_observation_covariance", p.gps_observation_covariance },
    { "gps_offset_initial_std", p.gps_offset_initial_std },
    { "gps_offset_drift", p.gps_offset_drift },
    { "gps_vision_timeout", p.gps_vision_timeout },
    { "gps_pad_height", p.gps_pad_height },
    { "initial_gps_height_std", p.initial_gps_height_std },
    { "max_coast_time", p.max_coast_time },
    { "gate_threshold", p.gate_threshold },
    { "max_consecutive_rejections", static_cast<double>(p.max_consecutive_rejections) },
    { "initial_velocity_std", p.initial_velocity_std },
    { "initial_acceleration_std", p.initial_acceleration_std },
    { "initial_turn_rate_std", p.initial_turn_rate_std },
    { "heading_acquisition_std", p.heading_acquisition_std },
    { "heading_loss_std", p.heading_loss_std },
    { "low_speed_regularisation", p.low_speed_regularisation },
    { "max_integration_step", p.max_integration_step },
  };
}

// Keys of the node itself (frames, output timing, the GPS antenna offset, how late a measurement may be), not
// of the filter.
const std::set<std::string> kNodeKeys = { "world_frame",      "time_step",        "path_time",     "pub_freq",
                                          "gps_pad_offset_x", "gps_pad_offset_y", "fusion_horizon" };
}  // namespace

TEST(KalmanConfig, EveryFilterParameterInTheYamlEqualsTheDefault)
{
  const YAML::Node config = YAML::LoadFile(KALMAN_YAML);
  for (const auto& [key, value] : filterDefaults())
  {
    ASSERT_TRUE(config[key]) << key << " is missing from " << KALMAN_YAML;
    EXPECT_DOUBLE_EQ(config[key].as<double>(), value) << key << " in " << KALMAN_YAML
                                                      << " differs from FilterParameters' default";
  }
}

TEST(KalmanConfig, EveryKeyOfTheYamlIsAFilterParameterOrTheNodes)
{
  const YAML::Node config = YAML::LoadFile(KALMAN_YAML);
  const auto defaults = filterDefaults();
  for (const auto& entry : config)
  {
    const auto key = entry.first.as<std::string>();
    EXPECT_TRUE(defaults.count(key) || kNodeKeys.count(key)) << key << " in " << KALMAN_YAML
                                                             << " is neither a filter parameter nor the node's";
  }
  for (const auto& key : kNodeKeys)
    EXPECT_TRUE(config[key]) << key << " is missing from " << KALMAN_YAML;
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
