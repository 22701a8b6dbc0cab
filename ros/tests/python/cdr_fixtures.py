"""CDR fixtures from an encoder independent of fusiond's: rosbags' own
serializer and type store (ROS 2 Jazzy), and rosbags' REP-2011 hashes.
Prints JSON: {"hashes": {type: hash}, "messages": {name: hex}}."""

import json
import sys

from rosbags.typesys import Stores, get_typestore

S = get_typestore(Stores.ROS2_JAZZY)
T = S.types


def time(sec, nanosec):
    return T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def header(frame):
    return T["std_msgs/msg/Header"](stamp=time(1432235497, 988949113), frame_id=frame)


def v3(x, y, z):
    return T["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)


def quat(x, y, z, w):
    return T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)


def arr(n, scale):
    import numpy
    return numpy.array([scale * (i + 1) for i in range(n)], dtype=numpy.float64)


def pose_cov():
    P = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=1.0, y=2.0, z=3.0),
                                    orientation=quat(0.0, 0.0, 0.6, 0.8))
    return T["geometry_msgs/msg/PoseWithCovariance"](pose=P, covariance=arr(36, 0.01))


def twist_cov():
    tw = T["geometry_msgs/msg/Twist"](linear=v3(1.5, -0.1, 0.0), angular=v3(0.0, 0.0, 0.3))
    return T["geometry_msgs/msg/TwistWithCovariance"](twist=tw, covariance=arr(36, 0.001))


messages = {
    "sensor_msgs/msg/Imu": T["sensor_msgs/msg/Imu"](
        header=header("imu_link"), orientation=quat(0.0, 0.0, 0.0, 1.0), orientation_covariance=arr(9, 0.1),
        angular_velocity=v3(0.01, 0.02, 0.03), angular_velocity_covariance=arr(9, 0.001),
        linear_acceleration=v3(0.1, 0.2, 9.8), linear_acceleration_covariance=arr(9, 0.01)),
    "nav_msgs/msg/Odometry": T["nav_msgs/msg/Odometry"](
        header=header("odom"), child_frame_id="base_link", pose=pose_cov(), twist=twist_cov()),
    "sensor_msgs/msg/NavSatFix": T["sensor_msgs/msg/NavSatFix"](
        header=header("gps"), status=T["sensor_msgs/msg/NavSatStatus"](status=0, service=1),
        latitude=48.137, longitude=11.575, altitude=520.5, position_covariance=arr(9, 0.5),
        position_covariance_type=2),
    "geometry_msgs/msg/TwistWithCovarianceStamped": T["geometry_msgs/msg/TwistWithCovarianceStamped"](
        header=header("base_link"), twist=twist_cov()),
    "geometry_msgs/msg/PoseWithCovarianceStamped": T["geometry_msgs/msg/PoseWithCovarianceStamped"](
        header=header("map"), pose=pose_cov()),
    "sensor_msgs/msg/FluidPressure": T["sensor_msgs/msg/FluidPressure"](
        header=header("baro"), fluid_pressure=101325.0, variance=4.0),
    "sensor_msgs/msg/MagneticField": T["sensor_msgs/msg/MagneticField"](
        header=header("mag"), magnetic_field=v3(2e-5, 0.0, -4e-5), magnetic_field_covariance=arr(9, 1e-12)),
    "rosgraph_msgs/msg/Clock": T["rosgraph_msgs/msg/Clock"](clock=time(1432235497, 988949113)),
    "tf2_msgs/msg/TFMessage": T["tf2_msgs/msg/TFMessage"](transforms=[T["geometry_msgs/msg/TransformStamped"](
        header=header("odom"), child_frame_id="base_link",
        transform=T["geometry_msgs/msg/Transform"](translation=v3(1.0, 2.0, 3.0), rotation=quat(0.0, 0.0, 0.6, 0.8)))]),
    "diagnostic_msgs/msg/DiagnosticArray": T["diagnostic_msgs/msg/DiagnosticArray"](
        header=header(""), status=[T["diagnostic_msgs/msg/DiagnosticStatus"](
            level=b"\x01"[0], name="fusiond: estimate", message="degraded: imu stale", hardware_id="",
            values=[T["diagnostic_msgs/msg/KeyValue"](key="rewinds", value="3")])]),
}

out = {
    "hashes": {t: S.hash_rihs01(t) for t in sys.argv[1:]},
    "messages": {t: bytes(S.serialize_cdr(m, t)).hex() for t, m in messages.items()},
}
print(json.dumps(out))
