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
//!
//! Each stream also carries its settings of its kind (its `[sensor.<table>]`),
//! read and checked by its kind ([`KindCatalog`]) and held here without their
//! type ([`Settings`]): the frames name no kind.

use std::any::Any;
use std::cell::OnceCell;
use std::fmt::Debug;
use std::sync::Arc;

use fusion_shared::SampleKind;
use fusion_shared::geodesy::Datum;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use serde::Deserialize;

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

/// What reading the `[[sensor]]` entries needs to know of each kind. The kind
/// list above the frames gives it (`measurement::Kinds`): each kind's module
/// declares whether its samples are rotated, and the type and the reading of
/// its table.
pub trait KindCatalog {
    /// Whether samples of `kind` are in the sensor's own axes, so that a
    /// rotation and an axis convention apply (the others are in the world
    /// frame, or a scalar along the body's x axis).
    fn rotated(&self, kind: SampleKind) -> bool;

    /// The key of `kind`'s settings table in a `[[sensor]]` entry
    /// (`[sensor.<key>]`), if the kind has one.
    fn table(&self, kind: SampleKind) -> Option<&'static str>;

    /// A sensor's settings of `kind` from its table (`None`: not given),
    /// checked; an error names the key (`key(field)`).
    fn settings(
        &self,
        kind: SampleKind,
        table: Option<&toml::Value>,
        key: &dyn Fn(&str) -> String,
    ) -> Result<Settings, ConfigError>;

    /// What a sensor of `kind` with `settings` observes ([`Observes`]).
    fn observes(&self, kind: SampleKind, settings: &Settings) -> Observes;

    /// The check of the whole configuration that `kind` makes of its
    /// sensors (`sensors`, every configured stream), if it makes one (one
    /// relative pose sensor per fusiond): the error names the sensor and says
    /// why.
    fn check_sensors(&self, kind: SampleKind, sensors: &[MountedSensor]) -> Result<(), ConfigError>;
}

/// What a sensor's samples let the `ins` model observe, as its kind declares
/// it (`Measurement::observes`, from the sensor's settings): what turns the
/// `ins` model's yaw rule (its `observability` module) and its gravity
/// reference on or off. A kind that declares nothing
/// observes nothing: it gives no heading, so the yaw is never learnt from it
/// (the safe side; a test over the kind list checks each declaration against
/// the kind's observation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Observes {
    /// The heading: a change of the yaw alone changes what the sensor reads
    /// (a compass, a world velocity as the vehicle moves, a map frame's yaw).
    pub heading: bool,
    /// The horizontal position (east and north).
    pub horizontal_position: bool,
    /// The tilt through a position, a velocity or an attitude, so the
    /// accelerometer's specific force is checked against them (what keeps
    /// roll and pitch without the gravity reference).
    pub tilt: bool,
}

impl Observes {
    /// Nothing: the default of a kind that declares nothing.
    pub const NOTHING: Self = Self { heading: false, horizontal_position: false, tilt: false };
    /// Heading, horizontal position and tilt (a position fix, a full pose).
    pub const ALL: Self = Self { heading: true, horizontal_position: true, tilt: true };
}

/// A sensor's settings of its kind, of the type its kind's module declares
/// (`Measurement::Settings`), or none. Held here without their type, so the
/// frames know no kind; [`Settings::get`] gives them typed.
#[derive(Clone, Default)]
pub struct Settings(Option<Arc<dyn SettingsValue>>);

/// What a kind's settings type is: any value, with its `Debug`.
pub trait SettingsValue: Any + Debug + Send + Sync {}
impl<T: Any + Debug + Send + Sync> SettingsValue for T {}

impl Settings {
    /// The settings `value`.
    pub fn new<S: SettingsValue>(value: S) -> Self {
        Self(Some(Arc::new(value)))
    }

    /// The settings, if they are an `S`.
    #[inline]
    pub fn get<S: SettingsValue>(&self) -> Option<&S> {
        let value: &dyn Any = self.0.as_deref()?;
        value.downcast_ref()
    }
}

impl Debug for Settings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.0 {
            Some(v) => v.fmt(f),
            None => f.write_str("none"),
        }
    }
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
pub struct SensorConfig {
    /// A name for logs and status ("gnss", "imu-left").
    pub name: String,
    /// Its sensor id ([`fusion_shared::SampleHeader::sensor`]).
    pub id: u32,
    /// The kinds of sample it publishes under that id (a GNSS receiver:
    /// `["geodetic", "velocity"]`).
    pub kinds: Vec<String>,
    /// Its axis convention (rotated kinds only: [`KindCatalog::rotated`]).
    #[serde(default)]
    pub axes: Axes,
    /// Rotation of its (FLU) axes into the body frame: roll, pitch, yaw in
    /// degrees, applied as `Rz(yaw) Ry(pitch) Rx(roll)` (rotated kinds only).
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
    /// The ROS topic its samples come from when a bag is replayed (`fusiond
    /// replay --input robot.bag`): each of its kinds is taken from that
    /// topic's messages (`fusiond replay`'s ROS bag reading).
    #[serde(default)]
    pub topic: Option<String>,
    /// Its kinds' settings tables, each read by its kind (`[sensor.quality]`
    /// of a geodetic sensor, `[sensor.magnetic]` of a magnetometer, ...:
    /// [`KindCatalog::table`]); any other key is an error.
    #[serde(flatten)]
    pub tables: toml::Table,
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
    /// Average, live: the snapshot of an IMU instant goes out after the sample
    /// that completes it (every IMU of the instant before has sent one); when
    /// one is missing, at the latest this long after the instant's first sample
    /// arrived, ns (with `--wait event`, as soon as the loop would sleep). 0: a
    /// snapshot after every sample. Estimates do not depend on it.
    pub instant_wait_ns: u64,
}

impl Default for ImuConfig {
    fn default() -> Self {
        Self { combine: Combine::Average, failover_after_ns: 20_000_000, instant_wait_ns: DEFAULT_INSTANT_WAIT_NS }
    }
}

/// The default of [`ImuConfig::instant_wait_ns`]: a quarter of a 1 kHz IMU's
/// interval, ns.
pub const DEFAULT_INSTANT_WAIT_NS: u64 = 250_000;

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

/// A configured sensor stream: its kind and id, its name, its mount, its settings.
#[derive(Debug, Clone)]
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
    /// Its settings of its kind (the kind's table, checked; [`Settings::get`]).
    pub settings: Settings,
    /// What it observes, as its kind declares from its settings.
    pub observes: Observes,
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
    /// or axis convention only for a rotated kind, no lever arm for an IMU, at
    /// most [`MAX_IMUS`] IMUs, each table read by its kind (`kinds`), and each
    /// kind's check of its sensors together ([`KindCatalog::check_sensors`]).
    pub fn from_config(
        datum: Option<Datum>,
        sensors: &[SensorConfig],
        imu: ImuConfig,
        kinds: &dyn KindCatalog,
    ) -> Result<Self, ConfigError> {
        let mut frames = Self::new(datum);
        frames.imus.config = imu;
        if imu.failover_after_ns == 0 {
            return Err(invalid("imu.failover_after_ns", "must be > 0"));
        }
        for (i, s) in sensors.iter().enumerate() {
            let key = |field: &str| format!("sensor[{i}] ({:?}).{field}", s.name);
            let own = check_entry(s, kinds, &key)?;
            frames.offsets |= s.time_offset_ns != 0;
            for (name, &kind) in s.kinds.iter().zip(&own) {
                frames.add_stream(s, name, kind, kinds, &key)?;
            }
        }
        for &kind in SampleKind::ALL {
            kinds.check_sensors(kind, &frames.sensors)?;
        }
        Ok(frames)
    }

    /// Adds the stream of kind `kind` (named `name` in its `kinds`) of entry `s`:
    /// once per (kind, id), an IMU at the origin and among at most [`MAX_IMUS`],
    /// a rotation only for a rotated kind, its settings read by its kind.
    fn add_stream(
        &mut self,
        s: &SensorConfig,
        name: &str,
        kind: SampleKind,
        kinds: &dyn KindCatalog,
        key: &dyn Fn(&str) -> String,
    ) -> Result<(), ConfigError> {
        if self.sensors.iter().any(|m| m.kind == kind && m.id == s.id) {
            return Err(invalid(key("id"), format!("{name} sensor {} is configured twice", s.id)));
        }
        let rotated = s.axes != Axes::Flu || s.rotation_rpy_deg != [0.0; 3];
        if kind == SampleKind::Imu {
            if s.lever_arm_m != [0.0; 3] {
                return Err(invalid(
                    key("lever_arm_m"),
                    "an IMU is the body origin: give the other sensors' lever arms from it",
                ));
            }
            if self.imus.ids.len() == MAX_IMUS {
                return Err(invalid(key("id"), format!("at most {MAX_IMUS} IMUs")));
            }
            self.imus.ids.push(s.id);
        } else if rotated && !kinds.rotated(kind) {
            let of: Vec<&str> = SampleKind::ALL.iter().filter(|&&k| kinds.rotated(k)).map(|k| k.name()).collect();
            return Err(invalid(
                key("rotation_rpy_deg"),
                format!(
                    "a rotation or axis convention applies to the kinds in the sensor's own axes ({}), not to {name}",
                    of.join(", ")
                ),
            ));
        }
        let table = kinds.table(kind).and_then(|t| s.tables.get(t));
        let table_key = |f: &str| match (kinds.table(kind), f) {
            (Some(t), "") => key(t),
            (t, f) => key(&format!("{}.{f}", t.unwrap_or("settings"))),
        };
        let settings = kinds.settings(kind, table, &table_key)?;
        let observes = kinds.observes(kind, &settings);
        self.sensors.push(MountedSensor {
            kind,
            id: s.id,
            name: s.name.clone(),
            mount: Mount::new(s.axes, s.rotation_rpy_deg.map(f64::to_radians), s.lever_arm_m),
            time_offset_ns: s.time_offset_ns,
            settings,
            observes,
        });
        Ok(())
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

    /// The settings of sensor `sensor` of `kind`, if it is configured and they
    /// are an `S` (the kind's type: `measurement::settings` gives
    /// them by the kind's sample type).
    #[inline]
    pub fn settings<S: SettingsValue>(&self, kind: SampleKind, sensor: u32) -> Option<&S> {
        self.sensors.iter().find(|m| m.kind == kind && m.id == sensor)?.settings.get()
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

/// Checks what a `[[sensor]]` entry says of the device as a whole: some kinds,
/// all known (returned), finite angles within ±360°, a time offset within
/// [`MAX_TIME_OFFSET_NS`], a finite lever arm of at most [`MAX_LEVER_ARM_M`],
/// and tables of its own kinds only.
fn check_entry(
    s: &SensorConfig,
    kinds: &dyn KindCatalog,
    key: &dyn Fn(&str) -> String,
) -> Result<Vec<SampleKind>, ConfigError> {
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
    let arm = Vector3::from(s.lever_arm_m);
    if !(arm.iter().all(|v| v.is_finite()) && arm.norm() <= MAX_LEVER_ARM_M) {
        return Err(invalid(key("lever_arm_m"), format!("must be finite and at most {MAX_LEVER_ARM_M} m long")));
    }
    let own = s
        .kinds
        .iter()
        .map(|name| {
            SampleKind::from_name(name).ok_or_else(|| {
                let known: Vec<&str> = SampleKind::ALL.iter().map(|k| k.name()).collect();
                invalid(key("kinds"), format!("unknown kind {name:?}; known: {}", known.join(", ")))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    check_tables(s, &own, kinds, key)?;
    Ok(own)
}

/// Checks that each table of `s` belongs to one of its kinds (`own`): an unknown
/// key, or the table of a kind the sensor does not have, is an error.
fn check_tables(
    s: &SensorConfig,
    own: &[SampleKind],
    kinds: &dyn KindCatalog,
    key: &dyn Fn(&str) -> String,
) -> Result<(), ConfigError> {
    for name in s.tables.keys() {
        match SampleKind::ALL.iter().find(|&&k| kinds.table(k) == Some(name.as_str())) {
            Some(kind) if !own.contains(kind) => {
                return Err(invalid(
                    key(name),
                    format!("applies to a {0} sensor: the sensor has no kind \"{0}\"", kind.name()),
                ));
            }
            Some(_) => {}
            None => {
                let tables = SampleKind::ALL.iter().filter_map(|&k| kinds.table(k));
                let known: Vec<&str> = SENSOR_KEYS.iter().copied().chain(tables).collect();
                return Err(invalid(key(name), format!("unknown key; a [[sensor]] has {}", known.join(", "))));
            }
        }
    }
    Ok(())
}

/// The keys of a `[[sensor]]` entry besides its kinds' tables.
const SENSOR_KEYS: [&str; 8] =
    ["name", "id", "kinds", "axes", "rotation_rpy_deg", "lever_arm_m", "time_offset_ns", "topic"];

#[cfg(test)]
mod tests;
