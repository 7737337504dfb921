// prediction_kalman_node: Kalman prediction of the landing pad's path (see prediction_node.h).
#include "ped_traj_pred/prediction_node.h"

int main(int argc, char** argv)
{
  ros::init(argc, argv, "prediction_kalman_node");
  ros::NodeHandle nh, private_nh("~");
  try
  {
    ped_traj_pred::PredictionNode node(nh, private_nh);
    ros::spin();
  }
  catch (const ped_traj_pred::ParameterError& error)
  {
    ROS_FATAL("%s", error.what());
    return 1;
  }
  return 0;
}
