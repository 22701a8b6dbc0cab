//! `fusion-sim`'s flags of the simulated sensors, each kind's declared in its
//! own module (`sim/<kind>.rs`: a `clap::Args` struct, [`KindFlags`]) and
//! gathered here from the kind list ([`KindsFlags`]), with the flags of the
//! whole drive ([`DriveFlags`]) and the parsers the kinds share.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::ScenarioConfig;

/// The flags of the whole drive that the sensors' flags read: their faults.
#[derive(clap::Args, Clone, Debug)]
pub struct DriveFlags {
    /// Probability of a lost fix (and of a lost sample of the sensors that drop some).
    #[arg(long, default_value_t = 0.0)]
    pub dropouts: f64,
    /// Probability of a gross outlier.
    #[arg(long, default_value_t = 0.0)]
    pub outliers: f64,
}

/// A kind's `fusion-sim` flags: what they add to the drive. Each kind's
/// module declares them for its wire type (`type Flags`), and
/// [`KindsFlags`] takes them from the kind list.
pub trait KindFlags {
    /// The kind's flags.
    type Flags: clap::Args + clap::FromArgMatches + Clone + std::fmt::Debug;

    /// Adds the kind's sensor to `c` as `flags` say (its settings, or an aiding
    /// sensor if its rate is above 0), after the kinds before it in the list
    /// (`all`: every kind's flags, for the kinds of one receiver).
    fn apply(flags: &Self::Flags, drive: &DriveFlags, all: &KindsFlags, c: &mut ScenarioConfig) -> anyhow::Result<()>;
}

/// Gathers each kind's flags from the kind list, in kind order.
macro_rules! kinds_flags {
    ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident;)*) => {
        /// Every kind's flags ([`KindFlags`]), in kind order.
        #[derive(clap::Args, Clone, Debug)]
        pub struct KindsFlags {
            $(
                #[doc = concat!("The ", $name, " sensor's flags.")]
                #[command(flatten)]
                pub $module: <fusion_shared::$ty as KindFlags>::Flags,
            )*
        }

        impl KindsFlags {
            /// Adds each kind's sensor to `c`, in kind order (the IMU and the
            /// position fixes first: the GNSS kinds after them read their
            /// receiver's settings).
            pub fn apply(&self, drive: &DriveFlags, c: &mut ScenarioConfig) -> anyhow::Result<()> {
                $(<fusion_shared::$ty as KindFlags>::apply(&self.$module, drive, self, c)?;)*
                Ok(())
            }
        }

    };
}
fusion_shared::for_each_sample_kind!(kinds_flags);

/// Three comma-separated numbers of option `name`, if given.
pub fn triple(name: &str, values: Option<&[f64]>) -> anyhow::Result<Option<[f64; 3]>> {
    values
        .map(|v| {
            <[f64; 3]>::try_from(v).map_err(|_| anyhow::anyhow!("{name}: expected three numbers X,Y,Z, got {v:?}"))
        })
        .transpose()
}

/// Two comma-separated numbers of option `name` (`example` shows them).
pub fn pair(name: &str, values: &[f64], example: &str) -> anyhow::Result<[f64; 2]> {
    <[f64; 2]>::try_from(values).map_err(|_| anyhow::anyhow!("{name}: expected {example}"))
}

/// A sensor mount (`--imu-mount`, `--magnetometer-mount`, `--twist-mount`), `AXES:ROLL,PITCH,YAW`
/// (degrees), as the rotation body ← sensor.
pub fn parse_mount(flag: &str, text: &str) -> anyhow::Result<Matrix3<f64>> {
    let bad = || anyhow::anyhow!("{flag} {text:?}: expected AXES:ROLL,PITCH,YAW, e.g. frd:3,-2,90");
    let (axes, angles) = text.split_once(':').ok_or_else(bad)?;
    let flip = match axes {
        "flu" => Vector3::new(1.0, 1.0, 1.0),
        "frd" => Vector3::new(1.0, -1.0, -1.0),
        _ => return Err(bad()),
    };
    let rpy: Vec<f64> =
        angles.split(',').map(|a| a.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| bad())?;
    let [roll, pitch, yaw] = <[f64; 3]>::try_from(rpy).map_err(|_| bad())?.map(f64::to_radians);
    Ok(UnitQuaternion::from_euler_angles(roll, pitch, yaw).to_rotation_matrix().into_inner()
        * Matrix3::from_diagonal(&flip))
}
