//! Attitude: the orientation an AHRS reports (an IMU with its own attitude
//! filter), fused by `ins` about all three axes or about roll and pitch only.
//!
//! With the attitude `R` (world ← body), the sensor's mounting `C` (body ←
//! sensor), the sample's rotation `Z` (world ← sensor) and its covariance `Σ`
//! about the sensor's axes (`Z_true = Z Exp(ε)`, `ε ~ N(0, Σ)`):
//!
//! **Full attitude** (`[sensor.attitude] yaw = true`, the default):
//!
//! ```text
//! Ŝ = R C,   y = Log(Ŝᵀ Z),   H = [0  0  Cᵀ  0  0],   R_y = Σ
//! ```
//!
//! (local attitude error `R_true = R Exp(δθ)`, so `Ŝᵀ S_true ≈ Exp(Cᵀ δθ)`;
//! the attitude rows of the pose update, [`super::pose`]).
//!
//! **Roll and pitch only** (`yaw = false`: an AHRS whose magnetic yaw is not to
//! be trusted indoors): the direction of world up in the sensor's axes,
//! measured `u_z = Zᵀ e₃`, predicted `u = Cᵀ Rᵀ e₃`, compared across `u` (the
//! component along `u` is of second order). With `a`, `b` an orthonormal basis
//! of the plane normal to `u` and `P = [aᵀ; bᵀ]`:
//!
//! ```text
//! y = P (u_z − u),   H = [0  0  P Cᵀ [Rᵀe₃]×  0  0],   R_y = P [u]× Σ [u]×ᵀ Pᵀ
//! ```
//!
//! (`R_trueᵀ e₃ = (I − [δθ]×) Rᵀ e₃ = Rᵀe₃ + [Rᵀe₃]× δθ`; and
//! `u_z = Exp(ε) u_true ≈ u_true − [u]× ε`.) A rotation about world up moves
//! neither `u` nor `u_z`: the yaw is neither corrected nor made more certain.
//! This is PX4 EKF2's gravity fusion with the AHRS's own tilt as the vector.
//!
//! **Alignment.** An attitude not yet known — a heading 1σ above
//! [`ALIGN_ABOVE_SD`] or a tilt above [`MAX_ATTITUDE_SD`] in full mode, the
//! tilt alone in roll/pitch mode — is set from the sample instead of being
//! linearised across a large error: `R = Z Cᵀ` with `P_θθ = C Σ Cᵀ` (full), or
//! the tilt of `Z Cᵀ` under the estimate's own yaw, `R = R_z(ψ − ψ_Z) Z Cᵀ`, with
//! `P_θθ = T C Σ Cᵀ Tᵀ + σ_ψ² u_b u_bᵀ` (`u_b = Rᵀ e₃`, `T = I − u_b u_bᵀ`;
//! the heading's variance kept), the attitude's correlations with the other
//! states dropped. The estimate's attitude then is the sensor's, and its
//! uncertainty the sample's.
//!
//! - `ins`: the updates above, Joseph form, gated, injected and reset; an
//!   unconfigured sensor id fuses the full attitude in the body's axes.
//! - `linear`: refused (no attitude); a config naming an attitude sensor is
//!   refused at start-up.
//!
//! Validation: finite; the quaternion of unit norm within
//! [`QUATERNION_NORM_TOLERANCE`]; covariance symmetric positive definite, of
//! a roll-and-pitch sensor only its block across the measured up direction
//! (the tilt's), a zero variance there floored (`tilt_sigma`). Not required by
//! the health; stale after 1 s once seen.

#![allow(non_snake_case)]

pub mod settings;
pub use settings::AttitudeConfig;

use fusion_shared::{AttitudeSample, SampleKind};
use nalgebra::{Matrix2, Matrix3, Quaternion, Rotation3, SMatrix, SVector, UnitQuaternion, Vector2, Vector3};

use super::components::VARIANCE_FLOOR;
use super::{Fuse, Limits, Measurement, Needed, Observation, Observe, Rejection, SYMMETRY_TOLERANCE, covariance3, finite};
use crate::model::ins::course::{ALIGN_ABOVE_SD, heading_variance};
use crate::model::ins::nonholonomic::{MAX_ATTITUDE_SD, tilt_variance};
use crate::model::ins::{InsModel, InsState};
use crate::model::{Model, StepOutcome};
use crate::setting::ConfigError;

use super::pose::unit_quaternion;
pub use super::pose::QUATERNION_NORM_TOLERANCE;

impl Measurement for AttitudeSample {
    const RANK: u8 = 2;
    /// The tilt, and the heading when its yaw is fused (`[sensor.attitude] yaw`).
    fn observes(settings: Option<&AttitudeConfig>) -> super::Observes {
        let yaw = settings.copied().unwrap_or_default().yaw;
        super::Observes { heading: yaw, tilt: true, ..super::Observes::NOTHING }
    }
    const LOCKOUT: super::LockoutRule = super::LockoutRule::Resets;
    const TIMEOUT_NS: u64 = 1_000_000_000;
    const NEEDED: Option<Needed> = None;
    /// An AHRS's orientation: its own filter's estimate.
    const FILTERED: bool = true;
    const ROTATED: bool = true;
    type Settings = AttitudeConfig;
    const TABLE: Option<&'static str> = Some("attitude");
    const TABLE_DOC: &'static str = r#"#   [sensor.attitude]                      # attitude, optional
#   yaw = true                             # false: roll and pitch only (a magnetic yaw indoors)
"#;

    /// All three angles without the table.
    fn settings(table: Option<&toml::Value>, key: &dyn Fn(&str) -> String) -> Result<Option<AttitudeConfig>, ConfigError> {
        super::read_table_or_default(table, key).map(Some)
    }

    fn fused_dim(settings: &AttitudeConfig) -> usize {
        if settings.yaw { 3 } else { 2 }
    }

    fn validate(&self, _: &Limits) -> Result<(), Rejection> {
        unit_quaternion(&self.orientation_wxyz)?;
        covariance3(&self.cov_rad2)
    }

    const VALIDATES_AS_SELECTED: bool = true;

    /// A sensor of roll and pitch only (`[sensor.attitude] yaw = false`):
    /// the quaternion as always, and of the covariance only its block across
    /// the measured up direction, the tilt's (`tilt_sigma`): the yaw's variance
    /// (an AHRS without a magnetometer sends 0 or −1 there) never counts.
    fn validate_as(&self, limits: &Limits, settings: Option<&AttitudeConfig>) -> Result<(), Rejection> {
        if settings.is_none_or(|c| c.yaw) {
            return self.validate(limits);
        }
        unit_quaternion(&self.orientation_wxyz)?;
        tilt_sigma(&self.cov_rad2, &rotation_of(&self.orientation_wxyz)).map(drop)
    }
}

/// The covariance a roll-and-pitch sample of rotation `Z` is fused with: of
/// `Σ`, only its block across the measured up direction `u_z = Zᵀ e₃` (in the
/// sensor's axes: the tilt's two axes, whatever the mount), `B = P Σ Pᵀ` with
/// `P` an orthonormal basis across `u_z`: symmetric, its eigenvalues below
/// [`VARIANCE_FLOOR`] raised to it (a driver's 0 about a world axis is not
/// on `B`'s diagonal), a negative one refused; along `u_z`, uncorrelated, the
/// larger eigenvalue in place of what was sent:
/// `Σ' = Pᵀ B P + λ_max u_z u_zᵀ`. The update projects across the estimated
/// up (`[u]×` in the module doc), which removes what lies along it: what a
/// driver sends for the yaw (0, −1: "not given") never counts.
fn tilt_sigma(cov: &[f64; 9], Z: &Matrix3<f64>) -> Result<Matrix3<f64>, Rejection> {
    finite(cov)?;
    let u = Z.transpose() * Vector3::z();
    let P = across(&u);
    let B = P * Matrix3::from_row_slice(cov) * P.transpose();
    let scale = B.amax();
    if (B - B.transpose()).amax() > SYMMETRY_TOLERANCE * scale {
        return Err(Rejection::CovarianceNotSymmetric);
    }
    let eigen = ((B + B.transpose()) * 0.5).symmetric_eigen();
    // Finite (checked above), so a plain comparison.
    if eigen.eigenvalues.min() < -SYMMETRY_TOLERANCE * scale {
        return Err(Rejection::CovarianceNotPositiveDefinite);
    }
    let values = eigen.eigenvalues.map(|l| l.max(VARIANCE_FLOOR));
    let B = eigen.eigenvectors * Matrix2::from_diagonal(&values) * eigen.eigenvectors.transpose();
    Ok(P.transpose() * B * P + u * u.transpose() * values.max())
}

/// A sample's rotation (sensor → world), normalised.
fn rotation_of(q: &[f64; 4]) -> Matrix3<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3])).to_rotation_matrix().into_inner()
}

/// The yaw of a rotation (world ← body), rad: the `ψ` of `R_z(ψ) R_y(θ) R_x(φ)`.
fn yaw_of(R: &Matrix3<f64>) -> f64 {
    R[(1, 0)].atan2(R[(0, 0)])
}

/// `Ŝ = R C` and `H` of the full attitude (see the module doc).
pub fn full<const D: usize>(s: &InsState<D>, C: &Matrix3<f64>) -> (Matrix3<f64>, SMatrix<f64, 3, D>) {
    let R = s.q().to_rotation_matrix().into_inner();
    let mut H = SMatrix::<f64, 3, D>::zeros();
    H.fixed_view_mut::<3, 3>(0, 6).copy_from(&C.transpose());
    (R * C, H)
}

/// An orthonormal basis of the plane normal to the unit vector `u`, as the rows
/// of `P`.
fn across(u: &Vector3<f64>) -> SMatrix<f64, 2, 3> {
    // The axis least along u, for a well-conditioned cross product.
    let k = u.iamin();
    let a = u.cross(&Vector3::ith(k, 1.0)).normalize();
    let b = u.cross(&a);
    SMatrix::<f64, 2, 3>::from_rows(&[a.transpose(), b.transpose()])
}

/// `u = Cᵀ Rᵀ e₃` (world up in the sensor's axes), the basis `P` across it and
/// `H` of the roll/pitch update (see the module doc).
pub fn tilt<const D: usize>(
    s: &InsState<D>,
    C: &Matrix3<f64>,
) -> (Vector3<f64>, SMatrix<f64, 2, 3>, SMatrix<f64, 2, D>) {
    let up_body = s.q().inverse_transform_vector(&Vector3::z());
    let u = C.transpose() * up_body;
    let P = across(&u);
    let mut H = SMatrix::<f64, 2, D>::zeros();
    H.fixed_view_mut::<2, 3>(0, 6).copy_from(&(P * C.transpose() * up_body.cross_matrix()));
    (u, P, H)
}

/// Whether the attitude is not yet known enough to linearise about (see the
/// module doc): the tilt, and with `yaw` the heading too.
fn unknown<const D: usize>(s: &InsState<D>, yaw: bool) -> bool {
    tilt_variance(s) > MAX_ATTITUDE_SD * MAX_ATTITUDE_SD
        || (yaw && heading_variance(s) > ALIGN_ABOVE_SD * ALIGN_ABOVE_SD)
}

/// Sets the attitude from the sample's rotation `Z` and covariance `Σ` (see the
/// module doc). Returns the change of the nominal state for the smoother's
/// record.
fn align<const D: usize>(
    model: &InsModel<D>,
    s: &mut InsState<D>,
    C: &Matrix3<f64>,
    Z: &Matrix3<f64>,
    Sigma: &Matrix3<f64>,
    yaw: bool,
) -> SVector<f64, D> {
    let old = s.q();
    let measured = Z * C.transpose();
    let R = if yaw {
        measured
    } else {
        let turn = yaw_of(&old.to_rotation_matrix().into_inner()) - yaw_of(&measured);
        Rotation3::from_axis_angle(&Vector3::z_axis(), turn).into_inner() * measured
    };
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(R));
    let heading_var = heading_variance(s);
    let body = C * Sigma * C.transpose();
    let block = if yaw {
        body
    } else {
        let u = q.inverse_transform_vector(&Vector3::z());
        let T = Matrix3::identity() - u * u.transpose();
        T * body * T.transpose() + u * u.transpose() * heading_var
    };
    model.reset_attitude(s, q, &block);
    let mut change = SVector::<f64, D>::zeros();
    change.fixed_rows_mut::<3>(6).copy_from(&(old.inverse() * q).scaled_axis());
    change
}

impl<const D: usize> Fuse<InsModel<D>> for AttitudeSample {
    fn fuse(&self, model: &InsModel<D>, s: &mut InsState<D>) -> (StepOutcome, Option<SVector<f64, D>>) {
        let frames = model.frames();
        let yaw = super::settings::<AttitudeSample>(frames, self.header.sensor).is_none_or(|c| c.yaw);
        let C = frames.mount(SampleKind::Attitude, self.header.sensor).rotation;
        let Z = rotation_of(&self.orientation_wxyz);
        let sigma = if yaw { Ok(Matrix3::from_row_slice(&self.cov_rad2)) } else { tilt_sigma(&self.cov_rad2, &Z) };
        let Ok(Sigma) = sigma else { return (StepOutcome::Refused, None) };
        if unknown(s, yaw) {
            return (StepOutcome::Propagated, Some(align(model, s, &C, &Z, &Sigma, yaw)));
        }
        if let Some(o) = self.observe(model, s) {
            return model.update_residual(s, &o.y, &o.H, &o.R);
        }
        let (u, P, H) = tilt(s, &C);
        let u_z = Z.transpose() * Vector3::z();
        let y: Vector2<f64> = P * (u_z - u);
        let ux = u.cross_matrix();
        let R = P * ux * Sigma * ux.transpose() * P.transpose();
        model.update_residual(s, &y, &H, &R)
    }
}

/// The full attitude: `y = Log(Ŝᵀ Z)` with `Ŝ = R C`, `H` of [`full`], `R = Σ`.
/// `None` for a sensor of roll and pitch only (`[sensor.attitude] yaw =
/// false`: two components, [`tilt`]) and while the attitude is unknown (the
/// sample sets it).
impl<const D: usize> Observe<InsModel<D>, 3, D> for AttitudeSample {
    fn observe(&self, model: &InsModel<D>, s: &InsState<D>) -> Option<Observation<3, D>> {
        let frames = model.frames();
        let yaw = super::settings::<AttitudeSample>(frames, self.header.sensor).is_none_or(|c| c.yaw);
        if !yaw || unknown(s, yaw) {
            return None;
        }
        let C = frames.mount(SampleKind::Attitude, self.header.sensor).rotation;
        let Z = rotation_of(&self.orientation_wxyz);
        let (S, H) = full(s, &C);
        let y = super::pose::log(&(S.transpose() * Z));
        Some(Observation { y, H, R: Matrix3::from_row_slice(&self.cov_rad2) })
    }
}

#[cfg(test)]
mod tests;
