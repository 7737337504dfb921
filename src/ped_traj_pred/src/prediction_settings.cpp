#include "ped_traj_pred/prediction_settings.h"

#include <cmath>
#include <sstream>
#include <utility>

namespace ped_traj_pred
{
namespace
{
std::string got(double value)
{
  std::ostringstream text;
  text << ", got " << value;
  return text.str();
}
}  // namespace

std::string PredictionSettings::validate() const
{
  if (std::string problem = filter.validate(); !problem.empty())
    return problem;
  if (!(std::isfinite(fusion_horizon) && fusion_horizon > 0.0))
    return "fusion_horizon must be > 0 [s]" + got(fusion_horizon);
  if (world_frame.empty())
    return "world_frame must not be empty";
  if (!(std::isfinite(time_step) && time_step > 0.0))
    return "time_step must be > 0 [s]" + got(time_step);
  if (!(std::isfinite(path_time) && path_time >= 0.0))
    return "path_time must be >= 0 [s]" + got(path_time);
  if (!(std::isfinite(pub_freq) && pub_freq > 0.0))
    return "pub_freq must be > 0 [Hz]" + got(pub_freq);
  if (!std::isfinite(gps_pad_offset.x()))
    return "gps_pad_offset_x is not finite [m]" + got(gps_pad_offset.x());
  if (!std::isfinite(gps_pad_offset.y()))
    return "gps_pad_offset_y is not finite [m]" + got(gps_pad_offset.y());
  // The optional inputs (relative_pose_topic, gps_topic) may be empty: that input is then off.
  for (const auto& [name, topic] : { std::pair<const char*, const std::string&>{ "pose_topic", pose_topic },
                                     { "future_path_topic", future_path_topic },
                                     { "odom_topic", odom_topic } })
    if (topic.empty())
      return std::string(name) + " must not be empty";
  return "";
}

}  // namespace ped_traj_pred
