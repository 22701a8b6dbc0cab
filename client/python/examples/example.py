import sys
import fusion_client as fc

# A namespace and an IMU id of its own: beside a live vehicle it must not publish as
# one of its sensors. Give it the namespace of a fusiond run to try it.
client = fc.Client(sys.argv[1] if len(sys.argv) > 1 else "fusion-example")
imu = client.publisher(fc.ImuSample, sensor=99)
state = client.state_reader()  # fc.DaemonNotRunning if no fusiond runs here
imu.publish(fc.ImuSample(accel_mps2=(0.1, 0.0, 0.0)), t_ns=fc.now_ns())
s = state.wait_next(timeout=1.0)
print(f"t_ns {s.t_ns} position {s.position.tolist()} sd {s.position_std.tolist()} health {s.health_name}")
