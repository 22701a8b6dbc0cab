"""Publishes 2 s of a stationary vehicle into fusiond in NAMESPACE with
fusion_client: a 100 Hz IMU (sensor 0) and 10 Hz position fixes (sensor 1) of
the origin with 0.5 m of noise (their stated σ), then one fix with a NaN, which must be refused before it is sent.

Usage: python publish.py NAMESPACE
"""

import random
import sys
import time

import fusion_client as fc


def main() -> int:
    client = fc.Client(sys.argv[1])
    imu = client.publisher(fc.ImuSample, sensor=0)
    gnss = client.publisher(fc.PositionSample, sensor=1)
    cov = (0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.25)
    t0 = fc.now_ns() - 3_000_000_000
    noise = random.Random(7)
    reached = 0
    for k in range(200):
        t = t0 + k * 10_000_000
        reached += imu.publish(fc.ImuSample(), t_ns=t)
        if k % 10 == 5:
            fix = tuple(noise.gauss(0.0, 0.5) for _ in range(3))
            reached += gnss.publish(fc.PositionSample(pos_m=fix, cov_m2=cov), t_ns=t)
        time.sleep(0.0005)
    bad = fc.PositionSample(pos_m=(float("nan"), 0.0, 0.0), cov_m2=cov)
    try:
        gnss.publish(bad, t_ns=t0 + 2_000_000_000)
        print("a NaN fix was sent")
        return 1
    except ValueError as e:
        print(f"refused: {e}")
    try:
        imu.publish(fc.PositionSample(cov_m2=cov))
        print("a fix was sent on the IMU service")
        return 1
    except TypeError as e:
        print(f"refused: {e}")
    print(f"published 220 samples, reached {reached}")
    # Stay connected until fusiond has taken them (it holds no sample of a gone publisher).
    time.sleep(1.0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
