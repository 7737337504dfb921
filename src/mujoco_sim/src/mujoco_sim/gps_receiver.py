"""A GPS receiver's messages as its ROS driver publishes them (nmea_navsat_driver's `fix` and `vel`): the
simulator's position fix (world frame, metres) as latitude/longitude/altitude around the world's datum
(/navsat_datum, config/datum.yaml), and its velocity as an ENU TwistStamped."""
import rospy
from geometry_msgs.msg import TwistStamped
from navsat_local.enu import LocalFrame, parse_datum
from sensor_msgs.msg import NavSatFix, NavSatStatus
from std_msgs.msg import Header

from .config import ConfigError

DATUM_PARAM = "/navsat_datum"
HORIZONTAL_STD_M = 2.5  # what a consumer receiver reports as its 1-sigma horizontal accuracy (its HDOP-based guess) [m]
VERTICAL_STD_M = 5.0    # ...and vertical [m]


class GpsReceiver:
    """``make_publisher(topic, type)``; topics ``prefix``/fix and ``prefix``/vel, frame ``frame_id``."""

    def __init__(self, make_publisher, prefix, frame_id):
        if not rospy.has_param(DATUM_PARAM):
            raise ConfigError("the parameter %s (the world's geodetic origin, {lat, lon, alt}) is not set: "
                             "sim.launch loads it from config/datum.yaml" % DATUM_PARAM)
        try:
            self.frame = LocalFrame.around(parse_datum(rospy.get_param(DATUM_PARAM), DATUM_PARAM))
        except ValueError as err:
            raise ConfigError("%s (sim.launch loads it from config/datum.yaml)" % err) from None
        self.frame_id = frame_id
        self.pub_fix = make_publisher(prefix + "/fix", NavSatFix)
        self.pub_vel = make_publisher(prefix + "/vel", TwistStamped)

    def messages(self, fix, stamp):
        """[(message, publisher)] for the simulator's ``fix`` ((position, velocity) in the world frame, or None in a
        dropout: the receiver then reports NO_FIX, as real ones do) at ``stamp``."""
        header = Header(stamp=stamp, frame_id=self.frame_id)
        if fix is None:
            return [(NavSatFix(header=header, status=NavSatStatus(status=NavSatStatus.STATUS_NO_FIX,
                                                                    service=NavSatStatus.SERVICE_GPS),
                               position_covariance_type=NavSatFix.COVARIANCE_TYPE_UNKNOWN), self.pub_fix)]
        position, velocity = fix
        lat, lon, alt = self.frame.to_geodetic(float(position[0]), float(position[1]), float(position[2]))
        message = NavSatFix(header=header, status=NavSatStatus(status=NavSatStatus.STATUS_FIX,
                                                               service=NavSatStatus.SERVICE_GPS),
                            latitude=lat, longitude=lon, altitude=alt,
                            position_covariance=[HORIZONTAL_STD_M ** 2, 0, 0, 0, HORIZONTAL_STD_M ** 2, 0,
                                                 0, 0, VERTICAL_STD_M ** 2],
                            position_covariance_type=NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN)
        twist = TwistStamped(header=header)
        twist.twist.linear.x, twist.twist.linear.y, twist.twist.linear.z = (float(v) for v in velocity)
        return [(message, self.pub_fix), (twist, self.pub_vel)]
