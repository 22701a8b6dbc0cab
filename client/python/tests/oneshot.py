"""Publishes one IMU sample as sensor SENSOR and exits at once (the interpreter's
exit waits until fusiond could take it). Usage: python oneshot.py NAMESPACE SENSOR"""

import sys

import fusion_client as fc

client = fc.Client(sys.argv[1])
imu = client.publisher(fc.ImuSample, sensor=int(sys.argv[2]))
imu.publish(fc.ImuSample(accel_mps2=(0.1, 0.0, 0.0)), t_ns=fc.now_ns())
