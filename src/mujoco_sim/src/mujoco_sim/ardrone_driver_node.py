"""The ROS side of the AR.Drone 2.0's driver, ardrone_autonomy, as the simulator emulates it (drone_model
ardrone2): the driver's topics, types, units and rates, so that the stack talks to the simulator as to the real
drone. Subscribes ``cmd_vel`` (normalised tilt, climb, yaw rate); publishes ``ardrone/navdata``
(ardrone_autonomy/Navdata, stamped when the driver publishes it, as the driver does); serves
``ardrone/setcamchannel`` and ``ardrone/togglecam`` (one camera streams at a time; SimNode renders the bottom
camera only while it is selected). ``ardrone/takeoff``, ``land``, ``reset`` and ``ardrone/imu`` stay SimNode's:
they are the same for both drone models."""
import rospy
from ardrone_autonomy.msg import Navdata as DriverNavdata
from ardrone_autonomy.srv import CamSelect, CamSelectResponse
from geometry_msgs.msg import Twist
from std_msgs.msg import Header
from std_srvs.srv import Empty as EmptyService, EmptyResponse

CHANNELS = 2  # the AR.Drone 2.0's cameras: 0 front, 1 bottom (the driver takes the channel modulo this)


class EmulatedArdroneDriver:
    """``node``: the SimNode (its simulator, action queue, publisher factory, lock-step bookkeeping)."""

    def __init__(self, node, make_publisher):
        self.node = node
        self.pub_navdata = make_publisher("ardrone/navdata", DriverNavdata)
        self.header = Header(frame_id="ardrone/base_link")
        rospy.Subscriber("cmd_vel", Twist, self._on_cmd_vel, queue_size=1, tcp_nodelay=True)
        rospy.Service("ardrone/setcamchannel", CamSelect, self._on_setcamchannel)
        rospy.Service("ardrone/togglecam", EmptyService, self._on_togglecam)

    @property
    def sim(self):
        return self.node.sim  # a reset of the world may build a new one

    def _on_cmd_vel(self, msg):
        problem = self.sim.set_ardrone_command(msg.linear.x, msg.linear.y, msg.linear.z,
                                               msg.angular.x, msg.angular.y, msg.angular.z)
        if problem:
            self.node.rejections.reject("cmd_vel", ("refused", "%s: the drone keeps its previous command; send "
                                                    "finite values in [-1, 1]" % problem))

    def _on_setcamchannel(self, request):
        channel = request.channel % CHANNELS  # as the driver does
        self.node.actions.put(lambda: self.sim.camera_channel.select(channel))
        rospy.loginfo("mujoco_sim: ardrone/setcamchannel %d (%s camera)", channel, ("front", "bottom")[channel])
        return CamSelectResponse(result=True)  # the driver always answers true

    def _on_togglecam(self, _request):
        self.node.actions.put(self.sim.camera_channel.toggle)
        return EmptyResponse()

    def step(self, now):
        """At each physics step: the packets the drone sends now go through the navdata link; the driver
        publishes at its loop ticks (or as they arrive, with realtime_navdata)."""
        schedule = self.sim.navdata_schedule
        link = self.sim.navdata_link
        for _ in range(schedule.samples_due(now)):
            if self.sim.link_lost() or (link.loss > 0.0 and link.lost_next()):
                continue
            packet = self.sim.ardrone_navdata()
            link.push(self.sim.time, lambda packet=packet: self._received(packet))
        packet = schedule.publish_due(now)
        if packet is not None:
            self._publish(packet)

    def _received(self, packet):
        if self.sim.navdata_schedule.received(packet) is not None:
            self._publish(packet)

    def _publish(self, packet):
        stamp = rospy.Time.from_sec(self.node.time_origin + self.sim.time)
        self.header.stamp = stamp
        self.pub_navdata.publish(DriverNavdata(header=self.header, **packet))
        self.node._published(self.pub_navdata, stamp)
