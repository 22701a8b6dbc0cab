"""Prints the typed accessors of each snapshot in a file of raw `StateSnapshot`
records as JSON lines (the test compares them with the Rust client's).

Usage: python typed.py FILE
"""

import ctypes
import json
import sys

import fusion_client as fc

NAMES = (
    "position", "velocity", "attitude", "roll_pitch_yaw", "accel_bias", "gyro_bias",
    "position_std", "velocity_std", "attitude_std", "roll_pitch_yaw_std", "accel_bias_std", "gyro_bias_std",
    "odometry_scale", "baro_bias", "pose_frame",
)


def main() -> int:
    data = open(sys.argv[1], "rb").read()
    size = ctypes.sizeof(fc.StateSnapshot)
    for at in range(0, len(data), size):
        s = fc.Snapshot(fc.StateSnapshot.from_buffer_copy(data[at : at + size]))
        line = {}
        for name in NAMES:
            v = getattr(s, name)
            line[name] = None if v is None else [float(c) for c in v]
        line["rejections"] = s.rejections
        print(json.dumps(line))
    return 0


if __name__ == "__main__":
    sys.exit(main())
