//! What the `ins` model does with its inputs between propagations: an IMU
//! sample's values held (combined over the IMUs, summed for the static
//! alignment), the model's own pseudo-measurements after it (standstill, the
//! motion constraint), and a wheel speed noted for the standstill detection.

use nalgebra::{SVector, UnitQuaternion, Vector3};

use super::{InsModel, InsState, N, gravity, nonholonomic, standstill};
use crate::model::held_imu::Held;

impl<const D: usize> InsModel<D> {
    /// Holds IMU `sensor`'s specific force `f` and rate `w` (body frame) at `t_ns`
    /// for the next propagations, combined with the other IMUs' as configured
    /// ([`HeldImu`](crate::model::held_imu::HeldImu)), summing them during the
    /// static alignment (aligning at its end). When the IMUs in use change
    /// ([`Held::Switched`]: a failover, or an IMU dropping out of or back into
    /// the mean), the bias variances grow back to at least their initial values:
    /// the biases held now are partly another IMU's.
    pub(crate) fn hold_imu(
        &self,
        s: &mut InsState<D>,
        sensor: u32,
        t_ns: u64,
        f: Vector3<f64>,
        w: Vector3<f64>,
    ) -> Held {
        let held = s.imu.hold(self.frames.imus(), sensor, t_ns, f, w);
        match held {
            Held::Held => {}
            Held::Switched => {
                let initial = &self.initial;
                s.kf.reset_error(|P| {
                    for i in 9..N {
                        P[(i, i)] = P[(i, i)].max(initial.variance(i));
                    }
                });
            }
            Held::Standby | Held::Unknown => return held,
        }
        if s.aligned < self.alignment_samples {
            s.sum_f += f;
            s.sum_w += w;
            s.aligned += 1;
            if s.aligned == self.alignment_samples {
                self.align(s);
            }
        }
        s.ready = s.aligned >= self.alignment_samples;
        held
    }

    /// The model's own pseudo-measurements after an IMU sample at `t_ns` whose
    /// body values `f`, `w` were held, once the state is ready, at most one
    /// update per sample: standstill detection and its updates
    /// ([`standstill`]), else the gravity reference where it is on
    /// ([`gravity`]), else, while the vehicle does not stand, the motion
    /// constraint when due (at most every `interval`: [`nonholonomic`]).
    /// Returns the correction injected, if any.
    pub(crate) fn pseudo_measurements(
        &self,
        s: &mut InsState<D>,
        t_ns: u64,
        f: Vector3<f64>,
        w: Vector3<f64>,
    ) -> Option<SVector<f64, D>> {
        if !s.ready {
            return None;
        }
        let mut injected = None;
        if let Some(c) = self.standstill() {
            injected = standstill::observe(c, self, s, t_ns, f, w);
        }
        if let Some((c, gate)) = self.gravity_reference()
            && injected.is_none()
        {
            injected = gravity::observe(c, gate, self, s, t_ns, f);
        }
        if let Some(c) = self.nonholonomic()
            && injected.is_none()
            && !s.standing()
            && s.constrained_ns.is_none_or(|last| t_ns >= last.saturating_add(c.interval_ns))
        {
            s.constrained_ns = Some(t_ns);
            injected = nonholonomic::fuse(c, self, s);
        }
        injected
    }

    /// Notes a wheel speed at `t_ns` for the standstill detection, if
    /// configured: wheels that turn end a standstill at once
    /// ([`standstill::Detector`]).
    pub(crate) fn note_speed(&self, s: &mut InsState<D>, t_ns: u64, speed_mps: f64) {
        if let Some(c) = self.standstill() {
            s.still.odometry(c, t_ns, speed_mps);
        }
    }

    /// The body angular rate `ω = ω_m − b_g` of the held IMU values (zero before
    /// any, and while the vehicle stands: [`standstill`]), rad/s.
    pub(crate) fn body_rate(s: &InsState<D>) -> Vector3<f64> {
        if s.still.standing {
            return Vector3::zeros();
        }
        s.imu.mean().map_or_else(Vector3::zeros, |(_, w, _)| w - s.b_g())
    }

    /// Static alignment from the mean specific force and rate (vehicle at rest):
    /// roll `φ = atan2(f̄_y, f̄_z)`, pitch `θ = atan2(−f̄_x, √(f̄_y² + f̄_z²))`
    /// (Groves 2013, eq. 5.101, body forward-left-up), yaw from x₀, and the gyro
    /// bias `b_g = ω̄` (at rest the gyro reads its bias, Earth rate neglected).
    fn align(&self, s: &mut InsState<D>) {
        let f = s.sum_f / f64::from(s.aligned);
        let w = s.sum_w / f64::from(s.aligned);
        let roll = f.y.atan2(f.z);
        let pitch = (-f.x).atan2((f.y * f.y + f.z * f.z).sqrt());
        let (_, _, yaw) = s.q().euler_angles();
        let q = UnitQuaternion::from_euler_angles(roll, pitch, yaw);
        let (p, v, b_a) = (s.p(), s.v(), s.b_a());
        s.put(p, v, q, b_a, w);
    }
}
