#!/usr/bin/env python3
"""A static transform on /tf_static, as tf2_ros's static_transform_publisher (which Debian's
packaged ROS 1 does not ship): arguments x y z yaw pitch roll parent child (metres, radians,
rotation about z, then y, then x). Latched; runs until shut down."""
import math
import sys

import rospy
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage


def quaternion(yaw, pitch, roll):
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    return (sr * cp * cy - cr * sp * sy,  # x
            cr * sp * cy + sr * cp * sy,  # y
            cr * cp * sy - sr * sp * cy,  # z
            cr * cp * cy + sr * sp * sy)  # w


def main():
    args = rospy.myargv(sys.argv)[1:]
    if len(args) != 8:
        sys.exit("usage: static_transform.py x y z yaw pitch roll parent child (found %d arguments)" % len(args))
    try:
        x, y, z, yaw, pitch, roll = (float(a) for a in args[:6])
    except ValueError as e:
        sys.exit("static_transform.py: x y z yaw pitch roll must be numbers: %s" % e)
    if not all(math.isfinite(v) for v in (x, y, z, yaw, pitch, roll)) or not args[6] or not args[7]:
        sys.exit("static_transform.py: expected finite numbers and two frame names, found %s" % " ".join(args))
    rospy.init_node("static_transform", anonymous=True)
    t = TransformStamped()
    t.header.stamp = rospy.Time.now()
    t.header.frame_id, t.child_frame_id = args[6], args[7]
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = x, y, z
    q = quaternion(yaw, pitch, roll)
    t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w = q
    pub = rospy.Publisher("/tf_static", TFMessage, queue_size=1, latch=True)
    pub.publish(TFMessage([t]))
    rospy.spin()


if __name__ == "__main__":
    main()
