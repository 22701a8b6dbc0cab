"""Publishes 2 s of a robot standing level and facing east into an `ins` fusiond in
NAMESPACE with fusion_client: a 100 Hz IMU (sensor 0), a 10 Hz magnetometer
(sensor 2: Munich's field, 3.5 deg declination, 64.5 deg inclination, 48.5 uT, in
the body's axes), a 10 Hz twist (sensor 4: standing still), a 10 Hz barometer
(sensor 5) and 10 Hz poses (sensor 6: standing still in a map turned against the
world); then a twist with a NaN in its covariance, which must be refused before it
is sent, and a pose whose quaternion is not of unit norm, which fusiond must refuse.

Usage: python publish_robot.py NAMESPACE
"""

import math
import sys
import time

import fusion_client as fc


def main() -> int:
    client = fc.Client(sys.argv[1])
    imu = client.publisher(fc.ImuSample, sensor=0)
    mag = client.publisher(fc.MagnetometerSample, sensor=2)
    twist = client.publisher(fc.TwistSample, sensor=4)
    baro = client.publisher(fc.BarometerSample, sensor=5)
    pose = client.publisher(fc.PoseSample, sensor=6)
    pose_cov = tuple((0.05**2 if k < 3 else 0.005**2) if r == k else 0.0 for r in range(6) for k in range(6))
    still = dict(position_m=(3.0, -1.0, 0.0), orientation_wxyz=(0.6, 0.0, 0.0, 0.8), cov=pose_cov)
    d, i, b = math.radians(3.5), math.radians(64.5), 48.5
    # ENU field; the body (forward-left-up) faces east, so body = (east, north, up).
    field = (b * math.cos(i) * math.sin(d), b * math.cos(i) * math.cos(d), -b * math.sin(i))
    mag_cov = (0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.25)
    twist_cov = tuple((0.05**2 if k < 3 else 0.01**2) if r == k else 0.0 for r in range(6) for k in range(6))
    t0 = fc.now_ns() - 3_000_000_000
    reached = 0
    for k in range(200):
        t = t0 + k * 10_000_000
        reached += imu.publish(fc.ImuSample(accel_mps2=(0.0, 0.0, 9.80665)), t_ns=t)
        if k % 10 == 3:
            reached += mag.publish(fc.MagnetometerSample(field_ut=field, cov_ut2=mag_cov), t_ns=t)
        if k % 10 == 7:
            reached += twist.publish(fc.TwistSample(cov=twist_cov), t_ns=t)
        if k % 10 == 5:
            reached += baro.publish(fc.BarometerSample(pressure_pa=95_000.0, var_pa2=4.0), t_ns=t)
            reached += pose.publish(fc.PoseSample(**still), t_ns=t)
        time.sleep(0.0005)
    bad = list(twist_cov)
    bad[35] = float("nan")
    try:
        twist.publish(fc.TwistSample(cov=tuple(bad)), t_ns=t0 + 2_000_000_000)
        print("a NaN twist was sent")
        return 1
    except ValueError as e:
        print(f"refused: {e}")
    skewed = dict(still, orientation_wxyz=(0.7, 0.0, 0.0, 0.8))
    reached += pose.publish(fc.PoseSample(**skewed), t_ns=t0 + 1_995_000_000)
    print(f"published 281 samples, reached {reached}")
    # Stay connected until fusiond has taken them (it holds no sample of a gone publisher).
    time.sleep(1.0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
