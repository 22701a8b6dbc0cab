"""A ROS 2 node's stand-in on rmw_zenoh, made of independent parts: Zenoh's
own Python package for the transport and `rosbags` for the bag and the CDR.

It announces itself as a node (liveliness tokens as rmw_zenoh declares them),
finds fusiond in the graph by a liveliness query on `@ros2_lv/<domain>/**`,
publishes a bag's first seconds of Imu and Odometry messages at their pace
(with `/clock`, as `ros2 bag play --clock` does) with rmw_zenoh's attachment,
and subscribes to fusiond's odometry, `/tf` and `/diagnostics` on the keys a
ROS node subscribes to: the published Jazzy type hashes. It checks every
attachment, decodes every message with rosbags, and writes what it saw as JSON.

With --hostile it also sends what a buggy peer sends: a message that does not
decode, one of another distribution's type hash, one without an attachment,
one of another type on the IMU topic, and a flood on a topic of its own.
"""

import argparse
import json
import struct
import sys
import time
from pathlib import Path

import zenoh
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

STORE = get_typestore(Stores.ROS2_JAZZY)
# The hashes ROS 2 Jazzy publishes for these types.
HASH = {
    "sensor_msgs/msg/Imu": "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b",
    "nav_msgs/msg/Odometry": "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
    "tf2_msgs/msg/TFMessage": "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
    "sensor_msgs/msg/MagneticField": "RIHS01_e80f32f56a20486c9923008fc1a1db07bbb273cbbf6a5b3bfa00835ee00e4dff",
    "sensor_msgs/msg/FluidPressure": "RIHS01_22dfb2b145a0bd5a31a1ac3882a1b32148b51d9b2f3bab250290d66f3595bc32",
}
# Types with no published value: rosbags' own REP-2011 hash.
for _t in ("diagnostic_msgs/msg/DiagnosticArray", "rosgraph_msgs/msg/Clock"):
    HASH[_t] = STORE.hash_rihs01(_t)


def dds(ros_type):
    package, _, name = ros_type.split("/")
    return f"{package}::msg::dds_::{name}_"


def key(domain, topic, ros_type):
    return f"{domain}/{topic.strip('/')}/{dds(ros_type)}/{HASH[ros_type]}"


class Node:
    """Tokens and publications as rmw_zenoh makes them."""

    def __init__(self, session, domain, name):
        self.session, self.domain, self.name = session, domain, name
        self.zid = str(session.info.zid())
        self.next_id = 1
        self.tokens = [session.liveliness().declare_token(self.token(0, "NN"))]
        self.gid = bytes(range(16))

    def token(self, entity, kind, rest=""):
        return f"@ros2_lv/{self.domain}/{self.zid}/0/{entity}/{kind}/%/%/{self.name}{rest}"

    def endpoint(self, kind, topic, ros_type, qos):
        rest = f"/{topic.replace('/', '%')}/{dds(ros_type)}/{HASH[ros_type]}/{qos}"
        self.tokens.append(self.session.liveliness().declare_token(self.token(self.next_id, kind, rest)))
        self.next_id += 1

    def attachment(self, seq):
        return struct.pack("<qq", seq, time.time_ns()) + b"\x10" + self.gid


def segment(bag, seconds, out):
    """The bag's first `seconds` of /imu/data and the wheels' odometry, and the
    same messages written as a ROS 2 bag (MCAP) for `fusiond replay`."""
    topics = {"/imu/data", "/husky_velocity_controller/odom"}
    messages = []
    with AnyReader([Path(bag)]) as reader:
        conns = [c for c in reader.connections if c.topic in topics]
        start = None
        for c, t, raw in reader.messages(connections=conns):
            start = t if start is None else start
            if t - start > seconds * 1e9:
                break
            messages.append((c.topic, c.msgtype, t, bytes(raw)))
    with Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {t: w.add_connection(t, ty, typestore=STORE) for t, ty in {(m[0], m[1]) for m in messages}}
        for topic, _, t, raw in messages:
            w.write(conns[topic], t, raw)
    return messages


def stamp_ns(msg):
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def graph(session, domain, name, timeout=30.0):
    """fusiond's tokens, found by a liveliness query on the domain."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = [str(r.ok.key_expr) for r in session.liveliness().get(f"@ros2_lv/{domain}/**") if r.ok]
        mine = [k for k in found if f"/%/%/{name}" in k]
        if any("/NN/" in k for k in mine) and any("%odometry%filtered" in k for k in mine):
            return mine
        time.sleep(0.1)
    sys.exit(f"fusiond not in the graph after {timeout} s")


class Received:
    """Messages of one fusiond topic, with their attachments checked."""

    def __init__(self, ros_type):
        self.ros_type, self.messages, self.problems, self.seqs, self.gids = ros_type, [], [], [], set()

    def __call__(self, sample):
        a = sample.attachment
        if a is None:
            self.problems.append("no attachment")
            return
        a = bytes(a.to_bytes())
        if len(a) != 33 or a[16] != 0x10:
            self.problems.append(f"attachment of {len(a)} bytes: {a.hex()}")
            return
        seq, _ = struct.unpack("<qq", a[:16])
        self.seqs.append(seq)
        self.gids.add(a[17:].hex())
        self.messages.append(STORE.deserialize_cdr(bytes(sample.payload.to_bytes()), self.ros_type))

    def checked(self):
        ordered = all(b == a + 1 for a, b in zip(self.seqs, self.seqs[1:]))
        return {"count": len(self.messages), "problems": self.problems, "seq_in_order": ordered,
                "first_seq": self.seqs[0] if self.seqs else None, "gids": len(self.gids)}


def hostile(node, session, domain, imu_raw, pressure):
    """What a buggy peer sends; fusiond's estimate must not change."""
    imu_key = key(domain, "/imu/data", "sensor_msgs/msg/Imu")
    session.put(imu_key, b"\x00\x01\x00\x00garbage", attachment=node.attachment(1))
    humble = f"{domain}/imu/data/{dds('sensor_msgs/msg/Imu')}/TypeHashNotSupported"
    session.put(humble, imu_raw, attachment=node.attachment(2))
    session.put(imu_key, imu_raw)
    mag = key(domain, "/imu/data", "sensor_msgs/msg/MagneticField")
    session.put(mag, imu_raw, attachment=node.attachment(3))
    flood = key(domain, "/flood/pressure", "sensor_msgs/msg/FluidPressure")
    for i in range(3000):
        session.put(flood, pressure, attachment=node.attachment(10 + i))


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--router", required=True)
    p.add_argument("--bag", required=True)
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--segment", required=True, help="where the bag's segment is written (MCAP)")
    p.add_argument("--result", required=True)
    p.add_argument("--domain", type=int, default=0)
    p.add_argument("--hostile", action="store_true")
    a = p.parse_args()

    messages = segment(a.bag, a.seconds, Path(a.segment))
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([a.router]))
    conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    # As rmw_zenoh's default session configuration: no shared memory.
    conf.insert_json5("transport/shared_memory/enabled", "false")
    session = zenoh.open(conf)
    node = Node(session, a.domain, "bag_player")
    for topic, ty in {(m[0], m[1]) for m in messages} | {("/clock", "rosgraph_msgs/msg/Clock")}:
        node.endpoint("MP", topic, ty, "::,10:,:,:,,")
    odometry, tf, diagnostics = (Received(t) for t in
                                 ("nav_msgs/msg/Odometry", "tf2_msgs/msg/TFMessage",
                                  "diagnostic_msgs/msg/DiagnosticArray"))
    subs = [
        session.declare_subscriber(key(a.domain, "/odometry/filtered", "nav_msgs/msg/Odometry"), odometry),
        session.declare_subscriber(key(a.domain, "/tf", "tf2_msgs/msg/TFMessage"), tf),
        session.declare_subscriber(key(a.domain, "/diagnostics", "diagnostic_msgs/msg/DiagnosticArray"),
                                   diagnostics),
    ]
    for topic, ty in (("/odometry/filtered", "nav_msgs/msg/Odometry"), ("/tf", "tf2_msgs/msg/TFMessage")):
        node.endpoint("MS", topic, ty, "::,10:,:,:,,")
    tokens = graph(session, a.domain, "fusiond")
    time.sleep(0.5)

    Clock = STORE.types["rosgraph_msgs/msg/Clock"]
    Time = STORE.types["builtin_interfaces/msg/Time"]
    clock_key = key(a.domain, "/clock", "rosgraph_msgs/msg/Clock")
    pubs = {t: session.declare_publisher(key(a.domain, t, ty)) for t, ty in {(m[0], m[1]) for m in messages}}
    seq, last_clock, stamps = 0, None, []
    first = STORE.deserialize_cdr(messages[0][3], messages[0][1])
    t0, wall0 = stamp_ns(first), time.monotonic_ns()
    Pressure = STORE.types["sensor_msgs/msg/FluidPressure"]
    Header = STORE.types["std_msgs/msg/Header"]
    for i, (topic, ty, _, raw) in enumerate(messages):
        t = stamp_ns(STORE.deserialize_cdr(raw, ty))
        stamps.append(t)
        delay = (wall0 + max(t - t0, 0)) - time.monotonic_ns()
        if delay > 0:
            time.sleep(delay * 1e-9)
        if last_clock is None or t - last_clock >= 10_000_000:
            c = Clock(clock=Time(sec=t // 1_000_000_000, nanosec=t % 1_000_000_000))
            seq += 1
            session.put(clock_key, bytes(STORE.serialize_cdr(c, "rosgraph_msgs/msg/Clock")),
                        attachment=node.attachment(seq))
            last_clock = t
        seq += 1
        pubs[topic].put(raw, attachment=node.attachment(seq))
        if a.hostile and i == len(messages) // 2:
            header = Header(stamp=Time(sec=t // 1_000_000_000, nanosec=t % 1_000_000_000), frame_id="baro")
            pressure = bytes(STORE.serialize_cdr(Pressure(header=header, fluid_pressure=101325.0, variance=0.0),
                                                 "sensor_msgs/msg/FluidPressure"))
            hostile(node, session, a.domain, raw, pressure)
    last = max(stamps)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and not any(stamp_ns(m) == last for m in odometry.messages):
        time.sleep(0.05)
    time.sleep(1.5)  # a diagnostics period
    for s in subs:
        s.undeclare()

    def odom(m):
        return {"stamp_ns": stamp_ns(m), "frame": m.header.frame_id, "child": m.child_frame_id,
                "position": [m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z],
                "orientation": [m.pose.pose.orientation.w, m.pose.pose.orientation.x,
                                m.pose.pose.orientation.y, m.pose.pose.orientation.z],
                "linear": [m.twist.twist.linear.x, m.twist.twist.linear.y, m.twist.twist.linear.z],
                "angular": [m.twist.twist.angular.x, m.twist.twist.angular.y, m.twist.twist.angular.z],
                "pose_cov": [float(v) for v in m.pose.covariance],
                "twist_cov": [float(v) for v in m.twist.covariance]}

    tf_last = tf.messages[-1].transforms[0] if tf.messages else None
    result = {
        "tokens": tokens,
        "sent": len(messages),
        "last_stamp_ns": last,
        "stamps": sorted(set(stamps)),
        "odometry": odometry.checked() | {"last": odom(odometry.messages[-1]) if odometry.messages else None,
                                          "all_stamps": [stamp_ns(m) for m in odometry.messages]},
        "tf": tf.checked() | {"last": None if tf_last is None else {
            "stamp_ns": stamp_ns(tf_last), "frame": tf_last.header.frame_id, "child": tf_last.child_frame_id,
            "translation": [tf_last.transform.translation.x, tf_last.transform.translation.y,
                            tf_last.transform.translation.z]}},
        "diagnostics": diagnostics.checked() | {"last": [
            {"name": s.name, "level": int(s.level), "message": s.message,
             "values": {v.key: v.value for v in s.values}}
            for s in (diagnostics.messages[-1].status if diagnostics.messages else [])]},
    }
    Path(a.result).write_text(json.dumps(result))
    session.close()


if __name__ == "__main__":
    main()
