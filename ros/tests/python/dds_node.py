"""A ROS 2 node's stand-in on DDS, made of independent parts: Cyclone DDS
(one of ROS 2's own middlewares, through its Python package) with ROS 2's DDS
names and types (`rt/<topic>`, `<pkg>::msg::dds_::<Type>_`, XCDR1), and
`rosbags` for the bag.

It finds fusiond in the graph (its node on `ros_discovery_info`, its writers
in DDS discovery), publishes a bag's first seconds of Imu and Odometry at their
pace with `/clock`, subscribes to fusiond's odometry, `/tf` and diagnostics,
and writes what it saw as JSON."""

import argparse
import json
import sys
import time
from dataclasses import dataclass, fields
from pathlib import Path

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, byte, float64, int8, int32, sequence, uint8, uint16, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

sys.path.insert(0, str(Path(__file__).parent))
from ros_node import segment, stamp_ns, STORE  # noqa: E402  (the same bag segment as rmw_zenoh's test)


def ros(name):
    package, _, ty = name.split("/")
    return f"{package}::msg::dds_::{ty}_"


@dataclass
class Time(IdlStruct, typename=ros("builtin_interfaces/msg/Time")):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename=ros("std_msgs/msg/Header")):
    stamp: Time
    frame_id: str


@dataclass
class Vector3(IdlStruct, typename=ros("geometry_msgs/msg/Vector3")):
    x: float64
    y: float64
    z: float64


@dataclass
class Point(IdlStruct, typename=ros("geometry_msgs/msg/Point")):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename=ros("geometry_msgs/msg/Quaternion")):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Pose(IdlStruct, typename=ros("geometry_msgs/msg/Pose")):
    position: Point
    orientation: Quaternion


@dataclass
class PoseWithCovariance(IdlStruct, typename=ros("geometry_msgs/msg/PoseWithCovariance")):
    pose: Pose
    covariance: array[float64, 36]


@dataclass
class Twist(IdlStruct, typename=ros("geometry_msgs/msg/Twist")):
    linear: Vector3
    angular: Vector3


@dataclass
class TwistWithCovariance(IdlStruct, typename=ros("geometry_msgs/msg/TwistWithCovariance")):
    twist: Twist
    covariance: array[float64, 36]


@dataclass
class Odometry(IdlStruct, typename=ros("nav_msgs/msg/Odometry")):
    header: Header
    child_frame_id: str
    pose: PoseWithCovariance
    twist: TwistWithCovariance


@dataclass
class Imu(IdlStruct, typename=ros("sensor_msgs/msg/Imu")):
    header: Header
    orientation: Quaternion
    orientation_covariance: array[float64, 9]
    angular_velocity: Vector3
    angular_velocity_covariance: array[float64, 9]
    linear_acceleration: Vector3
    linear_acceleration_covariance: array[float64, 9]


@dataclass
class Transform(IdlStruct, typename=ros("geometry_msgs/msg/Transform")):
    translation: Vector3
    rotation: Quaternion


@dataclass
class TransformStamped(IdlStruct, typename=ros("geometry_msgs/msg/TransformStamped")):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
class TFMessage(IdlStruct, typename=ros("tf2_msgs/msg/TFMessage")):
    transforms: sequence[TransformStamped]


@dataclass
class KeyValue(IdlStruct, typename=ros("diagnostic_msgs/msg/KeyValue")):
    key: str
    value: str


@dataclass
class DiagnosticStatus(IdlStruct, typename=ros("diagnostic_msgs/msg/DiagnosticStatus")):
    level: byte
    name: str
    message: str
    hardware_id: str
    values: sequence[KeyValue]


@dataclass
class DiagnosticArray(IdlStruct, typename=ros("diagnostic_msgs/msg/DiagnosticArray")):
    header: Header
    status: sequence[DiagnosticStatus]


@dataclass
class FluidPressure(IdlStruct, typename=ros("sensor_msgs/msg/FluidPressure")):
    header: Header
    fluid_pressure: float64
    variance: float64


@dataclass
class Clock(IdlStruct, typename=ros("rosgraph_msgs/msg/Clock")):
    clock: Time


@dataclass
class Gid(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
    data: array[uint8, 16]


@dataclass
class NodeEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"):
    node_namespace: str
    node_name: str
    reader_gid_seq: sequence[Gid]
    writer_gid_seq: sequence[Gid]


@dataclass
class ParticipantEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"):
    gid: Gid
    node_entities_info_seq: sequence[NodeEntitiesInfo]


IDL = {"sensor_msgs/msg/Imu": Imu, "nav_msgs/msg/Odometry": Odometry}


def to_idl(cls, m):
    """A rosbags message as Cyclone's type of the same definition."""
    kwargs = {}
    for f in fields(cls):
        v = getattr(m, f.name)
        t = f.type
        if isinstance(t, type) and issubclass(t, IdlStruct):
            v = to_idl(t, v)
        elif hasattr(v, "tolist"):
            v = [float(x) for x in v.tolist()]
        kwargs[f.name] = v
    return cls(**kwargs)


XCDR1 = Policy.DataRepresentation(use_cdrv0_representation=True)


def qos(reliable=True, depth=10, transient=False):
    p = [Policy.Reliability.Reliable(duration(seconds=1)) if reliable else Policy.Reliability.BestEffort,
         Policy.History.KeepLast(depth), XCDR1,
         Policy.Durability.TransientLocal if transient else Policy.Durability.Volatile]
    return Qos(*p)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--bag", required=True)
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--segment", required=True)
    p.add_argument("--result", required=True)
    p.add_argument("--hostile", action="store_true", help="a flood of pressure messages of unknown variance")
    a = p.parse_args()

    messages = segment(a.bag, a.seconds, Path(a.segment))
    dp = DomainParticipant(0)
    info = DataReader(dp, Topic(dp, "ros_discovery_info", ParticipantEntitiesInfo),
                      qos=qos(reliable=True, depth=1, transient=True))
    writers = {t: DataWriter(dp, Topic(dp, "rt" + t, IDL[ty]), qos=qos()) for t, ty in {(m[0], m[1]) for m in messages}}
    clock_writer = DataWriter(dp, Topic(dp, "rt/clock", Clock), qos=qos(reliable=False, depth=1))
    odom = DataReader(dp, Topic(dp, "rt/odometry/filtered", Odometry), qos=qos())
    tf = DataReader(dp, Topic(dp, "rt/tf", TFMessage), qos=qos(depth=100))
    diag = DataReader(dp, Topic(dp, "rt/diagnostics", DiagnosticArray), qos=qos())
    flood = DataWriter(dp, Topic(dp, "rt/flood/pressure", FluidPressure), qos=qos(depth=5000))

    # fusiond in the graph: its node on ros_discovery_info (what `ros2 node list` reads), with
    # its writers, and DDS discovery matching its odometry writer with this reader.
    deadline, nodes, writers_of = time.monotonic() + 30, set(), {}
    while time.monotonic() < deadline:
        for s in info.take(N=100):
            for n in s.node_entities_info_seq:
                nodes.add((n.node_namespace, n.node_name))
                writers_of[n.node_name] = len(n.writer_gid_seq)
        matched = odom.get_matched_publications()
        if ("/", "fusiond") in nodes and matched:
            break
        time.sleep(0.1)
    else:
        sys.exit(f"fusiond not in the graph: nodes {nodes}")
    time.sleep(1.0)  # the readers and writers match

    received = {"odometry": [], "tf": [], "diagnostics": []}

    def drain():
        received["odometry"] += odom.take(N=1000)
        received["tf"] += tf.take(N=1000)
        received["diagnostics"] += diag.take(N=1000)

    first = STORE.deserialize_cdr(messages[0][3], messages[0][1])
    t0, wall0, last_clock, stamps = stamp_ns(first), time.monotonic_ns(), None, []
    for i, (topic, ty, _, raw) in enumerate(messages):
        m = STORE.deserialize_cdr(raw, ty)
        t = stamp_ns(m)
        stamps.append(t)
        delay = (wall0 + max(t - t0, 0)) - time.monotonic_ns()
        if delay > 0:
            time.sleep(delay * 1e-9)
        if last_clock is None or t - last_clock >= 10_000_000:
            clock_writer.write(Clock(clock=Time(sec=t // 1_000_000_000, nanosec=t % 1_000_000_000)))
            last_clock = t
        writers[topic].write(to_idl(IDL[ty], m))
        if a.hostile and i == len(messages) // 2:
            header = Header(stamp=Time(sec=t // 1_000_000_000, nanosec=t % 1_000_000_000), frame_id="baro")
            for _ in range(3000):
                flood.write(FluidPressure(header=header, fluid_pressure=101325.0, variance=0.0))
        drain()
    last = max(stamps)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and not any(
            s.header.stamp.sec * 1_000_000_000 + s.header.stamp.nanosec == last for s in received["odometry"]):
        drain()
        time.sleep(0.05)
    time.sleep(1.5)
    drain()

    o = received["odometry"][-1] if received["odometry"] else None
    result = {
        "nodes": sorted(["/".join(n) for n in nodes]),
        "fusiond_writers": writers_of.get("fusiond", 0),
        "last_stamp_ns": last,
        "stamps": sorted(set(stamps)),
        "counts": {k: len(v) for k, v in received.items()},
        "odometry": None if o is None else {
            "stamp_ns": o.header.stamp.sec * 1_000_000_000 + o.header.stamp.nanosec,
            "frame": o.header.frame_id, "child": o.child_frame_id,
            "position": [o.pose.pose.position.x, o.pose.pose.position.y, o.pose.pose.position.z],
            "orientation": [o.pose.pose.orientation.w, o.pose.pose.orientation.x, o.pose.pose.orientation.y,
                            o.pose.pose.orientation.z]},
        "all_odometry_stamps": [s.header.stamp.sec * 1_000_000_000 + s.header.stamp.nanosec
                                for s in received["odometry"]],
        "tf_last": None if not received["tf"] else [received["tf"][-1].transforms[0].transform.translation.x,
                                                     received["tf"][-1].transforms[0].transform.translation.y,
                                                     received["tf"][-1].transforms[0].transform.translation.z],
        "diagnostics_names": sorted({s.name for d in received["diagnostics"] for s in d.status}),
    }
    Path(a.result).write_text(json.dumps(result))


if __name__ == "__main__":
    main()
