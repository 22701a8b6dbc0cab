"""Publishes 100 instants of two IMUs averaged (sensors 0 and 1, 100 Hz) into a
fusiond in NAMESPACE and reads the snapshots: one per instant (the first has
two: nothing to wait for yet), named after whichever sample completed it; then
an instant IMU 1 misses, whose snapshot names IMU 0's sample and comes after
fusiond's bounded wait, WAIT_NS.

Each instant is published once the one before is complete in fusiond: the
first once both of its samples have their snapshots (a new publisher's first
sample can reach fusiond after the samples sent behind it), every later one
once its snapshot came. A snapshot that went out at the bounded wait (this
process descheduled for that long between an instant's two publishes) is
counted apart: it is the wait doing its work.

Usage: python instants.py NAMESPACE WAIT_NS
"""

import sys
import time

import fusion_client as fc



def main() -> int:
    client = fc.Client(sys.argv[1])
    first = client.publisher(fc.ImuSample, sensor=0)
    last = client.publisher(fc.ImuSample, sensor=1)
    state = client.state_reader(buffer=256)
    time.sleep(0.2)  # fusiond connects to the new publishers
    t0 = fc.now_ns() - 2_000_000_000
    wait_ns = int(sys.argv[2])
    per_instant = {}
    waited_out = 0

    def await_snapshot(seq: int, sensor=None, timeout=2.0):
        """The first IMU snapshot of instant `seq` (of `sensor`'s sample if given),
        counting every IMU snapshot read by its instant."""
        nonlocal waited_out
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            s = state.wait_next(timeout=0.05)
            if s is None or s.input_kind != fc.ImuSample.KIND:
                continue
            if s.input_seq < 100 and s.input_sensor == 0 and s.publish_ns - s.input_received_ns >= wait_ns:
                waited_out += 1
                continue
            per_instant[s.input_seq] = per_instant.get(s.input_seq, 0) + 1
            if s.input_seq == seq and sensor in (None, s.input_sensor):
                return s
        return None

    for k in range(100):
        t = t0 + k * 10_000_000
        sample = fc.ImuSample(accel_mps2=(0.1, 0.0, 0.0))
        first.publish(sample, t_ns=t)
        last.publish(sample, t_ns=t)
        if await_snapshot(k, sensor=1 if k == 0 else None) is None:
            print(f"no snapshot of instant {k}")
            return 1
    # Whatever else came (a second snapshot of an instant would be here).
    await_snapshot(-1, timeout=0.2)
    counts = [per_instant[k] for k in range(1, 100)]
    print(
        f"100 instants: snapshots of the first {per_instant[0]}, of each later one {min(counts)} to {max(counts)}"
        f" (and {waited_out} at the wait)"
    )
    first.publish(fc.ImuSample(accel_mps2=(0.1, 0.0, 0.0)), t_ns=t0 + 100 * 10_000_000)
    s = await_snapshot(100, sensor=0)
    if s is None:
        print("no snapshot of instant 100")
        return 1
    print(f"an instant IMU 1 missed: its snapshot after {(s.publish_ns - s.input_received_ns) / 1e3:.0f} us")
    return 0


if __name__ == "__main__":
    sys.exit(main())
