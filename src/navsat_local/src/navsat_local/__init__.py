"""GPS fixes (sensor_msgs/NavSatFix) -> local ENU odometry around a datum: enu.py is the ROS-free core,
node.py the rospy node around it."""
