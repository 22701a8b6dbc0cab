//! The frames samples are given in besides the world frame: the datum of
//! geodetic fixes, and each sensor's mounting on the vehicle (`[[sensor]]`).
//!
//! The world frame is east-north-up about a datum. The datum is configured
//! (`[datum]`), or else it is the first valid geodetic fix the engine processes,
//! and once set it never changes for the rest of the run: every estimate and
//! snapshot is in the same frame, and `fusiond replay` of the same arrival order
//! picks the same datum as the live daemon did.
//!
//! The body frame is forward-left-up (REP-103) with its origin at the IMU: the
//! state's position and velocity are the IMU's. A sensor's mount gives
//!
//! - the rotation of its axes into the body frame, `C_bs` (body ← sensor): its
//!   axis convention first (FRD, as PX4 and ArduPilot publish: `diag(1, −1, −1)`
//!   into FLU), then a roll-pitch-yaw rotation `Rz(yaw) Ry(pitch) Rx(roll)` of
//!   those FLU sensor axes into the body axes; so `v_body = C_bs v_sensor`;
//! - its lever arm `l`: the position of its reference point (a GNSS antenna's
//!   phase centre, the odometry's axle point) in the body frame, m.
//!
//! A sensor without a `[[sensor]]` entry has the identity mount. Several IMUs sit
//! at the body origin (on one board); each may be rotated ([`ImuSet`]).

use std::cell::OnceCell;

use fusion_shared::SampleKind;
use fusion_shared::geodesy::Datum;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use serde::Deserialize;

use crate::gnss_quality::{GnssQuality, QualityConfig};
use crate::magnetic::{EarthField, MagneticConfig};
use crate::sensor_states::{AttitudeConfig, BarometerConfig, PoseConfig, TwistConfig};
use crate::setting::{ConfigError, invalid};

/// The `[datum]` table: the origin of the world frame, checked by [`Datum::new`].
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatumTable {
    latitude_deg: f64,
    longitude_deg: f64,
    height_m: f64,
}

impl DatumTable {
    /// The datum, or the error that names `datum`.
    pub fn datum(self) -> Result<Datum, ConfigError> {
        Datum::new(self.latitude_deg, self.longitude_deg, self.height_m).map_err(|e| invalid("datum", e.to_string()))
    }
}

/// Most IMUs combined ([`ImuSet`]).
pub const MAX_IMUS: usize = 8;

/// The kinds whose samples are in the sensor's own axes, so a rotation and an
/// axis convention apply (the others are in the world frame, or a scalar along
/// the body's x axis).
pub const ROTATED_KINDS: [SampleKind; 5] =
    [SampleKind::Imu, SampleKind::Magnetometer, SampleKind::Twist, SampleKind::Pose, SampleKind::Attitude];

/// An angle wrapped into (−π, π], rad.
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::PI;
    let w = a.rem_euclid(2.0 * PI); // [0, 2π)
    if w > PI { w - 2.0 * PI } else { w }
}

/// Longest lever arm accepted, m (a vehicle, not a survey baseline).
pub const MAX_LEVER_ARM_M: f64 = 100.0;

/// An axis convention of a sensor's own frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axes {
    /// Forward-left-up (REP-103), the body frame's.
    #[default]
    Flu,
    /// Forward-right-down (PX4, ArduPilot, aerospace).
    Frd,
}

/// One `[[sensor]]` entry as configured.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorConfig {
    /// A name for logs and status ("gnss", "imu-left").
    pub name: String,
    /// Its sensor id ([`fusion_shared::SampleHeader::sensor`]).
    pub id: u32,
    /// The kinds of sample it publishes under that id (a GNSS receiver:
    /// `["geodetic", "velocity"]`).
    pub kinds: Vec<String>,
    /// Its axis convention ([`ROTATED_KINDS`] only).
    #[serde(default)]
    pub axes: Axes,
    /// Rotation of its (FLU) axes into the body frame: roll, pitch, yaw in
    /// degrees, applied as `Rz(yaw) Ry(pitch) Rx(roll)` ([`ROTATED_KINDS`] only).
    #[serde(default)]
    pub rotation_rpy_deg: [f64; 3],
    /// Position of its reference point in the body frame, m (not for an IMU: the
    /// IMU is the body origin).
    #[serde(default)]
    pub lever_arm_m: [f64; 3],
    /// How late its timestamps are, ns: a sample stamped `t` is taken as valid at
    /// `t − time_offset_ns` (a constant delay of the sensor's clock or of its
    /// processing; negative if its clock is early). Applied before a sample is
    /// checked and ordered. At most [`MAX_TIME_OFFSET_NS`] either way.
    #[serde(default)]
    pub time_offset_ns: i64,
    /// How its geodetic fixes' reported quality maps to noise, and which fix
    /// types are refused (`[sensor.quality]`; [`crate::gnss_quality`]).
    #[serde(default)]
    pub quality: Option<QualityConfig>,
    /// The Earth's field at the site and the disturbance check of its
    /// magnetometer samples (`[sensor.magnetic]`; [`crate::magnetic`]).
    #[serde(default)]
    pub magnetic: Option<MagneticConfig>,
    /// Its barometer's bias state (`[sensor.barometer]`; defaults without it).
    #[serde(default)]
    pub barometer: Option<BarometerConfig>,
    /// Its pose samples' map frame (`[sensor.pose]`; estimated without it).
    #[serde(default)]
    pub pose: Option<PoseConfig>,
    /// Which of its attitude samples' angles are fused (`[sensor.attitude]`;
    /// all three without it).
    #[serde(default)]
    pub attitude: Option<AttitudeConfig>,
    /// Which components of its twists are fused (`[sensor.twist]`; all six
    /// without it).
    #[serde(default)]
    pub twist: Option<TwistConfig>,
    /// The ROS topic its samples come from when a bag is replayed (`fusiond
    /// replay --input robot.bag`): each of its kinds is taken from that
    /// topic's messages ([`fusion_shared::ros`]).
    #[serde(default)]
    pub topic: Option<String>,
}

/// The largest `[[sensor]] time_offset_ns` either way, ns (10 s): a sensor whose
/// clock is off by more is not one a fixed offset describes.
pub const MAX_TIME_OFFSET_NS: i64 = 10_000_000_000;

/// How samples of several IMUs are combined (`[imu] combine`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Combine {
    /// IMUs sampling at the same instants: the samples of one instant are
    /// averaged (after rotation into the body frame); an IMU that is missing at
    /// an instant is left out of that instant's mean.
    #[default]
    Average,
    /// IMUs on different clocks or rates: the first listed that is alive is
    /// used, the others stand by; after `failover_after_ns` without a sample of
    /// the one in use, the next alive one takes over.
    Failover,
}

/// `[imu]`: how several IMUs are combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImuConfig {
    /// Average or fail over.
    pub combine: Combine,
    /// Failover: the IMU in use is dead after this long without a sample
    /// (timestamps, so replay decides as live did), ns.
    pub failover_after_ns: u64,
}

impl Default for ImuConfig {
    fn default() -> Self {
        Self { combine: Combine::Average, failover_after_ns: 20_000_000 }
    }
}

/// Where a sensor sits and how its axes point (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mount {
    /// `C_bs`: body ← sensor.
    pub rotation: Matrix3<f64>,
    /// Lever arm in the body frame, m.
    pub lever_arm: Vector3<f64>,
    /// `rotation` is the identity (the sensor's values are used as they are).
    pub unrotated: bool,
    /// `lever_arm` is zero.
    pub at_origin: bool,
}

impl Mount {
    /// A sensor at the body origin with the body's axes.
    pub const IDENTITY: Mount = Mount {
        rotation: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        lever_arm: Vector3::new(0.0, 0.0, 0.0),
        unrotated: true,
        at_origin: true,
    };

    /// The mount of `axes`, then a roll-pitch-yaw rotation (rad), at `lever_arm` (m).
    pub fn new(axes: Axes, rpy_rad: [f64; 3], lever_arm: [f64; 3]) -> Self {
        let flip = match axes {
            Axes::Flu => Matrix3::identity(),
            Axes::Frd => Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)),
        };
        let [roll, pitch, yaw] = rpy_rad;
        let rotation = UnitQuaternion::from_euler_angles(roll, pitch, yaw).to_rotation_matrix().into_inner() * flip;
        let lever_arm = Vector3::from(lever_arm);
        Self {
            rotation,
            lever_arm,
            unrotated: rotation == Matrix3::identity(),
            at_origin: lever_arm == Vector3::zeros(),
        }
    }
}

/// The configured IMUs, in priority order, and how they are combined.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ImuSet {
    /// Configured IMU sensor ids; empty: any id, all treated as one IMU.
    ids: Vec<u32>,
    /// How they are combined.
    pub config: ImuConfig,
}

impl ImuSet {
    /// The index of IMU `sensor` among the configured ones (0 for any id when none
    /// is configured); `None`: an IMU that is not configured.
    pub fn index(&self, sensor: u32) -> Option<usize> {
        if self.ids.is_empty() { Some(0) } else { self.ids.iter().position(|&id| id == sensor) }
    }

    /// Number of configured IMUs (0: none configured, any id is accepted).
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// No IMU configured.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }
}

/// A configured sensor stream: its kind and id, its name, its mount.
#[derive(Debug, Clone, PartialEq)]
pub struct MountedSensor {
    /// Kind of its samples.
    pub kind: SampleKind,
    /// Its sensor id.
    pub id: u32,
    /// Its configured name.
    pub name: String,
    /// Where it sits.
    pub mount: Mount,
    /// How late its timestamps are, ns ([`SensorConfig::time_offset_ns`]).
    pub time_offset_ns: i64,
    /// Its fixes' quality mapping (geodetic only; the default elsewhere).
    pub quality: GnssQuality,
    /// The Earth's field it measures (magnetometer only).
    pub magnetic: Option<EarthField>,
    /// Its bias state's settings (barometer only).
    pub barometer: Option<BarometerConfig>,
    /// Its map frame (pose only).
    pub pose: Option<PoseConfig>,
    /// The angles it fuses (attitude only).
    pub attitude: Option<AttitudeConfig>,
    /// The components it fuses (twist only).
    pub twist: Option<TwistConfig>,
}

/// The datum of the world frame (set once) and the sensors' mounts.
#[derive(Debug, Clone, Default)]
pub struct Frames {
    datum: OnceCell<Datum>,
    sensors: Vec<MountedSensor>,
    imus: ImuSet,
    /// Some sensor has a time offset.
    offsets: bool,
}

impl Frames {
    /// Frames with the configured datum, or none yet (the first geodetic fix's),
    /// and no mounts.
    pub fn new(datum: Option<Datum>) -> Self {
        let cell = OnceCell::new();
        if let Some(d) = datum {
            let _ = cell.set(d);
        }
        Self { datum: cell, ..Self::default() }
    }

    /// Frames with the configured datum, sensors and IMU combination, checked:
    /// known kinds, no (kind, id) twice, finite angles and lever arms, a rotation
    /// or axis convention only for an IMU, no lever arm for an IMU, at most
    /// [`MAX_IMUS`] IMUs.
    pub fn from_config(datum: Option<Datum>, sensors: &[SensorConfig], imu: ImuConfig) -> Result<Self, ConfigError> {
        let mut frames = Self::new(datum);
        frames.imus.config = imu;
        if imu.failover_after_ns == 0 {
            return Err(invalid("imu.failover_after_ns", "must be > 0"));
        }
        for (i, s) in sensors.iter().enumerate() {
            let key = |field: &str| format!("sensor[{i}] ({:?}).{field}", s.name);
            if s.kinds.is_empty() {
                return Err(invalid(key("kinds"), "names no kind"));
            }
            if !s.rotation_rpy_deg.iter().all(|a| a.is_finite() && a.abs() <= 360.0) {
                return Err(invalid(key("rotation_rpy_deg"), "angles must be finite, within ±360°"));
            }
            if s.time_offset_ns.unsigned_abs() > MAX_TIME_OFFSET_NS.unsigned_abs() {
                return Err(invalid(
                    key("time_offset_ns"),
                    format!("{} ns is more than 10 s either way: not a constant delay", s.time_offset_ns),
                ));
            }
            frames.offsets |= s.time_offset_ns != 0;
            let quality = match &s.quality {
                Some(_) if !s.kinds.iter().any(|k| k == SampleKind::Geodetic.name()) => {
                    return Err(invalid(
                        key("quality"),
                        "applies to geodetic fixes: the sensor has no kind \"geodetic\"",
                    ));
                }
                Some(q) => GnssQuality::from_config(q, |f| key(&format!("quality.{f}")))?,
                None => GnssQuality::default(),
            };
            let has = |kind: SampleKind| s.kinds.iter().any(|k| k == kind.name());
            let magnetic = match &s.magnetic {
                Some(_) if !has(SampleKind::Magnetometer) => {
                    return Err(invalid(
                        key("magnetic"),
                        "applies to a magnetometer: the sensor has no kind \"magnetometer\"",
                    ));
                }
                Some(m) => Some(EarthField::from_config(m, |f| key(&format!("magnetic.{f}")))?),
                None if has(SampleKind::Magnetometer) => {
                    return Err(invalid(
                        key("magnetic"),
                        "a magnetometer needs the Earth's field at the site: declination_deg, inclination_deg and \
                         strength_ut (the World Magnetic Model's)",
                    ));
                }
                None => None,
            };
            let barometer = match &s.barometer {
                Some(_) if !has(SampleKind::Barometer) => {
                    return Err(invalid(
                        key("barometer"),
                        "applies to a barometer: the sensor has no kind \"barometer\"",
                    ));
                }
                Some(b) => Some(b.check(|f| key(&format!("barometer.{f}")))?),
                None => has(SampleKind::Barometer).then(BarometerConfig::default),
            };
            let pose = match &s.pose {
                Some(_) if !has(SampleKind::Pose) => {
                    return Err(invalid(key("pose"), "applies to a pose sensor: the sensor has no kind \"pose\""));
                }
                Some(p) => Some(p.check(|f| key(&format!("pose.{f}")))?),
                None => has(SampleKind::Pose).then(PoseConfig::default),
            };
            let twist = match &s.twist {
                Some(_) if !has(SampleKind::Twist) => {
                    return Err(invalid(key("twist"), "applies to a twist sensor: the sensor has no kind \"twist\""));
                }
                t => *t,
            };
            let attitude = match &s.attitude {
                Some(_) if !has(SampleKind::Attitude) => {
                    return Err(invalid(
                        key("attitude"),
                        "applies to an attitude sensor: the sensor has no kind \"attitude\"",
                    ));
                }
                Some(a) => Some(*a),
                None => has(SampleKind::Attitude).then(AttitudeConfig::default),
            };
            let arm = Vector3::from(s.lever_arm_m);
            if !(arm.iter().all(|v| v.is_finite()) && arm.norm() <= MAX_LEVER_ARM_M) {
                return Err(invalid(
                    key("lever_arm_m"),
                    format!("must be finite and at most {MAX_LEVER_ARM_M} m long"),
                ));
            }
            for name in &s.kinds {
                let kind = SampleKind::from_name(name).ok_or_else(|| {
                    let known: Vec<&str> = SampleKind::ALL.iter().map(|k| k.name()).collect();
                    invalid(key("kinds"), format!("unknown kind {name:?}; known: {}", known.join(", ")))
                })?;
                if frames.sensors.iter().any(|m| m.kind == kind && m.id == s.id) {
                    return Err(invalid(key("id"), format!("{name} sensor {} is configured twice", s.id)));
                }
                let rotated = s.axes != Axes::Flu || s.rotation_rpy_deg != [0.0; 3];
                if kind == SampleKind::Imu {
                    if arm != Vector3::zeros() {
                        return Err(invalid(
                            key("lever_arm_m"),
                            "an IMU is the body origin: give the other sensors' lever arms from it",
                        ));
                    }
                    if frames.imus.ids.len() == MAX_IMUS {
                        return Err(invalid(key("id"), format!("at most {MAX_IMUS} IMUs")));
                    }
                    frames.imus.ids.push(s.id);
                } else if rotated && !ROTATED_KINDS.contains(&kind) {
                    return Err(invalid(
                        key("rotation_rpy_deg"),
                        format!(
                            "a rotation or axis convention applies to an imu, a magnetometer, a twist, a pose or \
                             an attitude sensor only, not to {name}"
                        ),
                    ));
                }
                let rpy = s.rotation_rpy_deg.map(f64::to_radians);
                let mount = Mount::new(s.axes, rpy, s.lever_arm_m);
                let time_offset_ns = s.time_offset_ns;
                frames.sensors.push(MountedSensor {
                    kind,
                    id: s.id,
                    name: s.name.clone(),
                    mount,
                    time_offset_ns,
                    quality,
                    magnetic,
                    barometer: (kind == SampleKind::Barometer).then_some(barometer).flatten(),
                    pose: (kind == SampleKind::Pose).then_some(pose).flatten(),
                    attitude: (kind == SampleKind::Attitude).then_some(attitude).flatten(),
                    twist: (kind == SampleKind::Twist).then_some(twist).flatten(),
                });
            }
        }
        Ok(frames)
    }

    /// The datum, once there is one.
    pub fn datum(&self) -> Option<&Datum> {
        self.datum.get()
    }

    /// The datum, set to `first` if there was none.
    pub fn datum_or_set(&self, first: Datum) -> &Datum {
        self.datum.get_or_init(|| first)
    }

    /// The mount of sensor `sensor` of `kind` ([`Mount::IDENTITY`] if not configured).
    #[inline]
    pub fn mount(&self, kind: SampleKind, sensor: u32) -> &Mount {
        self.sensors.iter().find(|m| m.kind == kind && m.id == sensor).map_or(&Mount::IDENTITY, |m| &m.mount)
    }

    /// The quality mapping of geodetic sensor `sensor` (the default if not
    /// configured).
    pub fn quality(&self, sensor: u32) -> GnssQuality {
        self.sensors
            .iter()
            .find(|m| m.kind == SampleKind::Geodetic && m.id == sensor)
            .map_or_else(GnssQuality::default, |m| m.quality)
    }

    /// The Earth's field magnetometer `sensor` measures (`None`: not configured).
    pub fn magnetic(&self, sensor: u32) -> Option<&EarthField> {
        self.sensors.iter().find(|m| m.kind == SampleKind::Magnetometer && m.id == sensor)?.magnetic.as_ref()
    }

    /// The bias settings of barometer `sensor` (`None`: not configured).
    pub fn barometer(&self, sensor: u32) -> Option<&BarometerConfig> {
        self.sensors.iter().find(|m| m.kind == SampleKind::Barometer && m.id == sensor)?.barometer.as_ref()
    }

    /// The map frame settings of pose sensor `sensor` (`None`: not configured).
    pub fn pose(&self, sensor: u32) -> Option<&PoseConfig> {
        self.sensors.iter().find(|m| m.kind == SampleKind::Pose && m.id == sensor)?.pose.as_ref()
    }

    /// The components twist sensor `sensor` fuses (`None`: all six).
    pub fn twist(&self, sensor: u32) -> Option<&TwistConfig> {
        self.sensors.iter().find(|m| m.kind == SampleKind::Twist && m.id == sensor)?.twist.as_ref()
    }

    /// The angles attitude sensor `sensor` fuses (`None`: not configured; all
    /// three).
    pub fn attitude(&self, sensor: u32) -> Option<&AttitudeConfig> {
        self.sensors.iter().find(|m| m.kind == SampleKind::Attitude && m.id == sensor)?.attitude.as_ref()
    }

    /// How late the timestamps of sensor `sensor` of `kind` are, ns (0 if not
    /// configured).
    #[inline]
    pub fn time_offset_ns(&self, kind: SampleKind, sensor: u32) -> i64 {
        if !self.offsets {
            return 0;
        }
        self.sensors.iter().find(|m| m.kind == kind && m.id == sensor).map_or(0, |m| m.time_offset_ns)
    }

    /// Every configured sensor stream with its mount.
    pub fn sensors(&self) -> &[MountedSensor] {
        &self.sensors
    }

    /// The IMUs and how they are combined.
    pub fn imus(&self) -> &ImuSet {
        &self.imus
    }
}

#[cfg(test)]
mod tests;
