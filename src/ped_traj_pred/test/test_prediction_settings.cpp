// PredictionSettings::validate, which prediction_kalman_node applies at start-up and at each ~reset: usable
// settings pass, and each bad value is refused with a message that starts with the parameter's name.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "ped_traj_pred/prediction_settings.h"

namespace
{
using ped_traj_pred::PredictionSettings;

PredictionSettings usable()
{
  PredictionSettings s;
  s.pose_topic = "platform/current_platform_position_in_world";
  s.future_path_topic = "kalman_prediction_path";
  s.odom_topic = "kalman_platform_odom";
  return s;
}

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

TEST(PredictionSettings, UsableSettingsPass)
{
  EXPECT_EQ(usable().validate(), "");
  PredictionSettings without_optional_inputs = usable();  // no GPS, no relative fixes: vision only
  without_optional_inputs.gps_topic = without_optional_inputs.relative_pose_topic = "";
  EXPECT_EQ(without_optional_inputs.validate(), "");
  PredictionSettings zero_path_time = usable();  // the present position only
  zero_path_time.path_time = 0.0;
  EXPECT_EQ(zero_path_time.validate(), "");
}

TEST(PredictionSettings, EachBadValueIsRefusedNamingItsParameter)
{
  const std::vector<std::pair<std::string, std::function<void(PredictionSettings&)>>> cases = {
    { "fusion_horizon", [](PredictionSettings& s) { s.fusion_horizon = 0.0; } },
    { "fusion_horizon", [](PredictionSettings& s) { s.fusion_horizon = kNan; } },
    { "world_frame", [](PredictionSettings& s) { s.world_frame = ""; } },
    { "time_step", [](PredictionSettings& s) { s.time_step = -0.1; } },
    { "time_step", [](PredictionSettings& s) { s.time_step = kInf; } },
    { "path_time", [](PredictionSettings& s) { s.path_time = -1.0; } },
    { "pub_freq", [](PredictionSettings& s) { s.pub_freq = 0.0; } },
    { "pub_freq", [](PredictionSettings& s) { s.pub_freq = kNan; } },
    { "gps_pad_offset_x", [](PredictionSettings& s) { s.gps_pad_offset.x() = kNan; } },
    { "gps_pad_offset_y", [](PredictionSettings& s) { s.gps_pad_offset.y() = kInf; } },
    { "pose_topic", [](PredictionSettings& s) { s.pose_topic = ""; } },
    { "future_path_topic", [](PredictionSettings& s) { s.future_path_topic = ""; } },
    { "odom_topic", [](PredictionSettings& s) { s.odom_topic = ""; } },
    // The filter's own parameters are checked too (FilterParameters::validate).
    { "max_coast_time", [](PredictionSettings& s) { s.filter.max_coast_time = -1.0; } },
  };
  for (const auto& [name, spoil] : cases)
  {
    PredictionSettings s = usable();
    spoil(s);
    const std::string problem = s.validate();
    EXPECT_EQ(problem.rfind(name, 0), 0u) << "expected a problem starting with '" << name << "', got '" << problem
                                          << "'";
  }
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
