//! Pose: position and attitude from a localiser (lidar SLAM, visual-inertial
//! odometry, a map matcher) in a map frame of its own.
//!
//! The map frame is gravity-aligned; its yaw `ψ` and origin `t` in the world
//! frame are configured (`[sensor.pose] frame_yaw_deg`, `frame_origin_m`) or
//! four auxiliary states ([`crate::model::ins::aux`]). With `R_ψ = R_z(ψ)`, the
//! sensor's mounting `C` (body ← sensor) and lever arm `l`, the attitude `R`
//! and the sample's position `z_p` and rotation `Z` (sensor → map):
//!
//! ```text
//! m̂ = R_ψᵀ (p + R l − t)            (the sensor's position in the map)
//! Ŝ = R_ψᵀ R C                       (its attitude in the map)
//! y = [ z_p − m̂ ;  Log(Ŝᵀ Z) ]       (residual; attitude error in the sensor's axes)
//!
//! H = [ R_ψᵀ  0  −R_ψᵀ R [l]×  0  0 | (m̂_y, −m̂_x, 0)ᵀ   −R_ψᵀ ]
//!     [ 0     0   Cᵀ           0  0 | −Cᵀ Rᵀ e₃           0    ]
//!                                      δψ                  δt
//! ```
//!
//! (`R_z(ψ + δψ)ᵀ ≈ (I − δψ [e₃]×) R_ψᵀ`; local attitude error
//! `R_true = R Exp(δθ)`, so `Ŝᵀ S_true ≈ I + [Cᵀ δθ − δψ Cᵀ Rᵀ e₃]×`.) The
//! sample's 6×6 covariance is `R` as it is (position in the map frame,
//! attitude about the sensor's axes).
//!
//! **Setting the frame.** The first pose, a pose whose `reset_counter`
//! differs from the one the frame was set with (the localiser re-initialised:
//! its map jumped), or the `realign_after_gated`-th gated pose in a row (a
//! jump it did not announce) sets the frame instead of being fused:
//! `ψ = yaw(R C Zᵀ)`, `t = p + R l − R_ψ z_p`, with the covariance of the
//! linearised least-squares solution `a = A y`, `A = (H_aᵀ R⁻¹ H_a)⁻¹ H_aᵀ R⁻¹`
//! (`H_a`: the frame's columns of `H`), by state augmentation: `G_x = −A H_x`,
//! `G_z = A` (`aux::augment`, [`crate::model::ins::aux`]). The estimate does not
//! move; the frame's old value and correlations are dropped. A configured frame
//! is never set again (a counter change with a fixed frame is a relocalisation
//! in the same map, fused as usual).
//!
//! **Relative mode** (`[sensor.pose] relative = true`): for a localiser that
//! drifts like odometry, only the change between consecutive poses is fused, as
//! the sensor's twist over the interval `Δt` (robot_localization's
//! "differential" mode): `v = Z₁ᵀ (z_p₂ − z_p₁)/Δt`, `ω = Log(Z₁ᵀ Z₂)/Δt`, with
//! covariance `(Z₁ᵀ Σ_p₁ Z₁ + Z₁ᵀ Σ_p₂ Z₁)/Δt²` and `(Σ_θ₁ + Σ_θ₂)/Δt²` (the
//! two poses' cross-covariance neglected), through the twist's `h` and `H`
//! ([`super::twist`]). Poses are differenced in disjoint pairs (1–2, 3–4, …):
//! differences that shared a pose would have correlated noise, which the
//! filter, taking each as independent, would count twice as information
//! against once as noise. The mean over the
//! interval is taken for the value at its end: keep `Δt` short (≤ 0.1 s at
//! vehicle accelerations). A pose after a reset or more than
//! [`MAX_RELATIVE_GAP_NS`] after the last is not differenced.
//!
//! - `ins`: the update above, Joseph form, gated, injected and reset;
//!   relative poses refused until the attitude is known (as a twist).
//! - `linear`: refused (no attitude); a config naming a pose sensor is refused
//!   at start-up.
//!
//! Validation: finite; |position| ≤ [`MAX_POSITION_M`]; the quaternion of unit
//! norm within [`QUATERNION_NORM_TOLERANCE`]; covariance symmetric positive
//! definite; of a sensor with `fuse`, only what it selects (the quaternion
//! only with an attitude component), a zero variance floored. With a
//! selection, the first pose sets only the frame states it informs: `ψ` with
//! the yaw, the horizontal origin with `x` and `y`, the height with `z`.
//! Not required by the health; stale after 1 s once seen.

#![allow(non_snake_case)]

pub mod settings;
pub use fusion_shared::sample::pose_progress::{PoseProgress, PreviousPose};
pub use settings::PoseConfig;

use fusion_shared::snapshot::aux;
use fusion_shared::{PoseSample, SampleKind};
use nalgebra::{Matrix3, Quaternion, Rotation3, SMatrix, SVector, UnitQuaternion, Vector3, Vector6};

use super::components::selected_covariance;
use super::{Fuse, Limits, Measurement, Needed, Observation, Observe, Rejection, covariance, finite};
use crate::frames::{Mount, MountedSensor};
use crate::model::ins::aux::{AuxPrior, augment_some};

/// Standard deviation given the map frame's origin before the first pose
/// sets it, m.
const UNSET_ORIGIN_STD_M: f64 = 1000.0;
use crate::model::ins::{InsModel, InsState, nonholonomic};
use crate::model::{Model, StepOutcome};
use crate::setting::ConfigError;

/// The farthest position accepted, m.
pub const MAX_POSITION_M: f64 = 1e7;
/// How far from 1 a sample's quaternion norm may be.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;
/// The longest interval between two poses that relative mode differences, ns.
pub const MAX_RELATIVE_GAP_NS: u64 = 1_000_000_000;

impl Measurement for PoseSample {
    const RANK: u8 = 2;
    /// The tilt; the heading if it fuses its yaw, the horizontal position if
    /// it fuses both `x` and `y` (`[sensor.pose] fuse`; all of them by default).
    fn observes(settings: Option<&PoseConfig>) -> super::Observes {
        let Some(f) = settings.map(|c| c.fuse.mask) else { return super::Observes::ALL };
        super::Observes { heading: f[5], horizontal_position: f[0] && f[1], tilt: true }
    }
    const LOCKOUT: super::LockoutRule = super::LockoutRule::Resets;
    const NEEDS_ENTRY: Option<&'static str> = Some("its entry makes its map frame at start-up");
    const FEWER_AUX: &'static str = "a pose sensor's frame may be given: [sensor.pose] frame_yaw_deg, frame_origin_m";

    /// One relative pose sensor per fusiond: its last pose is kept in the state.
    fn check_sensors(sensors: &[MountedSensor]) -> Result<(), ConfigError> {
        let relative = |m: &&MountedSensor| m.settings.get::<PoseConfig>().is_some_and(|p| p.relative);
        match sensors.iter().filter(|m| m.kind == SampleKind::Pose).filter(relative).nth(1) {
            Some(second) => Err(crate::setting::invalid(
                "sensor",
                format!("{:?}: one relative pose sensor per fusiond (its last pose is kept in the state)", second.name),
            )),
            None => Ok(()),
        }
    }
    const TIMEOUT_NS: u64 = 1_000_000_000;
    const NEEDED: Option<Needed> = None;
    const ROTATED: bool = true;
    type Settings = PoseConfig;
    const TABLE: Option<&'static str> = Some("pose");
    const TABLE_DOC: &'static str = r#"#   [sensor.pose]                          # pose, optional: the map frame in the world
#   frame_yaw_deg = 30.0                   # configured (with frame_origin_m), or without both: estimated
#   frame_origin_m = [20.0, -15.0, 0.5]    #   (4 states, set at the first pose and at each localiser reset)
#   frame_yaw_random_walk_deg = 0.01       # estimated frame's drift, degrees/sqrt(s)
#   frame_origin_random_walk_m = 0.01      # and m/sqrt(s)
#   realign_after_gated = 5                # this many gated poses in a row: the map jumped, set the frame again
#   relative = false                       # true: fuse only the change between poses (a drifting localiser)
#   fuse = ["x", "y", "z", "roll", "pitch", "yaw"]   # the components fused (default all)
"#;

    /// The defaults (an estimated frame) without the table.
    fn settings(table: Option<&toml::Value>, key: &dyn Fn(&str) -> String) -> Result<Option<PoseConfig>, ConfigError> {
        super::read_table_or_default::<PoseConfig>(table, key)?.check(key).map(Some)
    }

    fn fused_dim(settings: &PoseConfig) -> usize {
        settings.fuse.count()
    }

    /// An estimated map frame (neither given nor relative): yaw and origin
    /// uninformed (σ π and 1 km) until the first pose aligns them, then
    /// random walks.
    fn aux_priors(settings: &PoseConfig) -> Vec<AuxPrior> {
        if !settings.estimated() {
            return Vec::new();
        }
        let yaw_rw = settings.frame_yaw_random_walk_deg.to_radians();
        let origin = AuxPrior { initial: 0.0, std: UNSET_ORIGIN_STD_M, random_walk: settings.frame_origin_random_walk_m };
        vec![AuxPrior { initial: 0.0, std: std::f64::consts::PI, random_walk: yaw_rw }, origin, origin, origin]
    }

    fn validate(&self, _: &Limits) -> Result<(), Rejection> {
        finite(&self.position_m)?;
        finite(&self.orientation_wxyz)?;
        if Vector3::from(self.position_m).norm() > MAX_POSITION_M {
            return Err(Rejection::OutOfRange);
        }
        unit_quaternion(&self.orientation_wxyz)?;
        covariance::<6>(&self.cov)
    }

    const VALIDATES_AS_SELECTED: bool = true;

    /// The components a sensor fuses (`[sensor.pose] fuse`; all six without
    /// it): the selected coordinates finite and within range, the quaternion
    /// finite and of unit norm only if an attitude component is selected, and
    /// the selected covariance block positive definite with a zero variance
    /// floored ([`selected_covariance`]). What is not selected (a drone
    /// driver's (0, 0, 0, 0) orientation and zero variances) is never looked
    /// at. A relative sensor differences whole poses: all of it is checked.
    fn validate_as(&self, limits: &Limits, settings: Option<&PoseConfig>) -> Result<(), Rejection> {
        let mask = match settings {
            Some(c) if !c.relative => c.fuse.mask,
            _ => return self.validate(limits),
        };
        let picked = Vector3::from_fn(|i, _| if mask[i] { self.position_m[i] } else { 0.0 });
        finite(picked.as_slice())?;
        if picked.norm() > MAX_POSITION_M {
            return Err(Rejection::OutOfRange);
        }
        if attitude_selected(&mask) {
            unit_quaternion(&self.orientation_wxyz)?;
        }
        selected_covariance(&self.cov, &mask).map(drop)
    }
}

/// A sample's quaternion `[w, x, y, z]`: finite, of unit norm within
/// [`QUATERNION_NORM_TOLERANCE`] (else out of range).
pub fn unit_quaternion(q: &[f64; 4]) -> Result<(), Rejection> {
    finite(q)?;
    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
        return Err(Rejection::OutOfRange);
    }
    Ok(())
}

/// Whether a selection fuses any of the attitude's components.
fn attitude_selected(mask: &[bool; 6]) -> bool {
    mask[3..].contains(&true)
}

/// The map frame a pose is predicted in: yaw, origin, and the error-state
/// index of its yaw when the frame is estimated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapFrame {
    /// Yaw of the map frame in the world frame, rad.
    pub yaw: f64,
    /// Its origin in the world frame, m.
    pub origin: Vector3<f64>,
    /// Error-state index of `ψ` (then `t_e, t_n, t_u`), when estimated.
    pub states: Option<usize>,
}

impl MapFrame {
    /// The frame of the state `s`: its estimated frame if `s` has one.
    pub fn estimated<const D: usize>(s: &InsState<D>) -> Option<Self> {
        s.aux_index(aux::POSE_FRAME_YAW).map(|i| Self::estimated_at(s, i))
    }

    /// The estimated frame of `s`, its yaw at error-state index `i`.
    fn estimated_at<const D: usize>(s: &InsState<D>, i: usize) -> Self {
        let origin = Vector3::new(s.aux_value(i + 1), s.aux_value(i + 2), s.aux_value(i + 3));
        Self { yaw: s.aux_value(i), origin, states: Some(i) }
    }
}

/// A sample's rotation (sensor → map), normalised.
fn rotation_of(q: &[f64; 4]) -> Matrix3<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3])).to_rotation_matrix().into_inner()
}

/// `Log(M)` of a rotation matrix: the rotation vector, rad, precise near the
/// identity (through the quaternion, `θ = 2 atan2(|v|, w)`; the matrix's
/// `acos((tr M − 1)/2)` loses half the digits there).
pub fn log(M: &Matrix3<f64>) -> Vector3<f64> {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*M));
    let (w, v) = (q.scalar(), q.vector().into_owned());
    let (w, v) = if w < 0.0 { (-w, -v) } else { (w, v) };
    let n = v.norm();
    if n < 1e-300 {
        return 2.0 * v;
    }
    v * (2.0 * n.atan2(w) / n)
}

fn yaw_matrix(yaw: f64) -> Matrix3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), yaw).into_inner()
}

/// `(m̂, Ŝ)`, the predicted position and attitude in the map, and `H` (see the
/// module doc) of a sensor mounted at `mount` in map frame `frame`.
pub fn pose<const D: usize>(
    s: &InsState<D>,
    mount: &Mount,
    frame: &MapFrame,
) -> (Vector3<f64>, Matrix3<f64>, SMatrix<f64, 6, D>) {
    let R = s.q().to_rotation_matrix().into_inner();
    let Rpt = yaw_matrix(frame.yaw).transpose();
    let C = mount.rotation;
    let l = mount.lever_arm;
    let m = Rpt * (s.p() + R * l - frame.origin);
    let S = Rpt * R * C;
    let mut H = SMatrix::<f64, 6, D>::zeros();
    H.fixed_view_mut::<3, 3>(0, 0).copy_from(&Rpt);
    H.fixed_view_mut::<3, 3>(0, 6).copy_from(&(-Rpt * R * l.cross_matrix()));
    H.fixed_view_mut::<3, 3>(3, 6).copy_from(&C.transpose());
    if let Some(i) = frame.states {
        H.fixed_view_mut::<3, 1>(0, i).copy_from(&Vector3::new(m.y, -m.x, 0.0));
        H.fixed_view_mut::<3, 3>(0, i + 1).copy_from(&(-Rpt));
        H.fixed_view_mut::<3, 1>(3, i).copy_from(&(-C.transpose() * R.transpose() * Vector3::z()));
    }
    (m, S, H)
}

/// The residual `[z_p − m̂; Log(Ŝᵀ Z)]` of the components `mask` selects (0
/// for the others, which are never read: the attitude's only if one of its
/// components is selected).
fn residual(m: &Vector3<f64>, S: &Matrix3<f64>, sample: &PoseSample, mask: &[bool; 6]) -> Vector6<f64> {
    let mut y = Vector6::zeros();
    if attitude_selected(mask) {
        let Z = rotation_of(&sample.orientation_wxyz);
        y.fixed_rows_mut::<3>(3).copy_from(&log(&(S.transpose() * Z)));
    }
    y.fixed_rows_mut::<3>(0).copy_from(&(Vector3::from(sample.position_m) - m));
    for (v, keep) in y.iter_mut().zip(mask) {
        if !keep {
            *v = 0.0;
        }
    }
    y
}

/// Which of the estimated frame's states `(ψ, t_e, t_n, t_u)` a pose of the
/// components `mask` selects sets: `ψ` with the yaw, the horizontal origin
/// with both `x` and `y`, the height with `z`.
fn frame_states_set(mask: &[bool; 6]) -> [bool; 4] {
    let horizontal = mask[0] && mask[1];
    [mask[5], horizontal, horizontal, mask[2]]
}

/// Sets the estimated map frame (states at `i..i + 4`) from `sample`, by
/// state augmentation (see the module doc), the states the selection `mask`
/// does not inform ([`frame_states_set`]: a sonar's height alone sets the
/// origin's height) left as they were, counted with the other states. The
/// least squares is over the selected rows: `R` is
/// [`selected_covariance`]'s, unit and uncorrelated where not selected, and
/// those rows of `H_a` are zero.
fn set_frame<const D: usize>(
    s: &mut InsState<D>,
    mount: &Mount,
    i: usize,
    sample: &PoseSample,
    R: &SMatrix<f64, 6, 6>,
    mask: &[bool; 6],
) -> bool {
    let set = frame_states_set(mask);
    let Rb = s.q().to_rotation_matrix().into_inner();
    let now = MapFrame::estimated_at(s, i);
    let yaw = if set[0] {
        let Z = rotation_of(&sample.orientation_wxyz);
        let M = Rb * mount.rotation * Z.transpose(); // world ← map, a yaw for a gravity-aligned map
        M[(1, 0)].atan2(M[(0, 0)])
    } else {
        now.yaw
    };
    let picked = Vector3::from_fn(|r, _| if mask[r] { sample.position_m[r] } else { 0.0 });
    let through = s.p() + Rb * mount.lever_arm - yaw_matrix(yaw) * picked;
    let pick = |r: usize| if set[r + 1] { through[r] } else { now.origin[r] };
    let origin = Vector3::new(pick(0), pick(1), pick(2));
    let frame = MapFrame { yaw, origin, states: Some(i) };
    let (_, _, mut H) = pose(s, mount, &frame);
    for r in (0..6).filter(|&r| !mask[r]) {
        H.row_mut(r).fill(0.0);
    }
    let mut Ha = H.fixed_view::<6, 4>(0, i).into_owned();
    for c in (0..4).filter(|&c| !set[c]) {
        Ha.column_mut(c).fill(0.0);
    }
    let Some(W) = R.try_inverse() else { return false };
    let mut N = Ha.transpose() * W * Ha;
    for c in (0..4).filter(|&c| !set[c]) {
        N[(c, c)] = 1.0;
    }
    let Some(N) = N.try_inverse() else { return false };
    let A: SMatrix<f64, 4, 6> = N * Ha.transpose() * W;
    let a = SVector::<f64, 4>::new(yaw, origin.x, origin.y, origin.z);
    augment_some(s, i, &set, &a, &(-A * H), &A, R).is_ok()
}

/// The upper triangle of the 3×3 block at `at` of a row-major 6×6 matrix.
fn upper(cov: &[f64; 36], at: usize) -> [f64; 6] {
    let e = |r: usize, c: usize| cov[(at + r) * 6 + at + c];
    [e(0, 0), e(0, 1), e(0, 2), e(1, 1), e(1, 2), e(2, 2)]
}

/// The symmetric 3×3 matrix of an upper triangle.
fn symmetric(u: &[f64; 6]) -> Matrix3<f64> {
    Matrix3::new(u[0], u[1], u[2], u[1], u[3], u[4], u[2], u[4], u[5])
}

/// The pose of `sample` as kept for relative mode.
fn previous(sample: &PoseSample) -> PreviousPose {
    PreviousPose {
        t_ns: sample.header.t_ns,
        sensor: sample.header.sensor,
        reset_counter: sample.reset_counter,
        position: sample.position_m,
        orientation_wxyz: sample.orientation_wxyz,
        cov_upper: [upper(&sample.cov, 0), upper(&sample.cov, 3)],
    }
}

/// The twist `[v; ω]` in the sensor's axes and its covariance between the
/// poses `a` and `b` (see the module doc), if they can be differenced.
pub fn relative_twist(a: &PreviousPose, b: &PreviousPose) -> Option<(Vector6<f64>, SMatrix<f64, 6, 6>)> {
    let gap = b.t_ns.checked_sub(a.t_ns).filter(|g| (1..=MAX_RELATIVE_GAP_NS).contains(g))?;
    if a.sensor != b.sensor || a.reset_counter != b.reset_counter {
        return None;
    }
    let dt = gap as f64 * 1e-9;
    let (Za, Zb) = (rotation_of(&a.orientation_wxyz), rotation_of(&b.orientation_wxyz));
    let Zt = Za.transpose();
    let v = Zt * (Vector3::from(b.position) - Vector3::from(a.position)) / dt;
    let w = log(&(Zt * Zb)) / dt;
    let pp = symmetric(&a.cov_upper[0]) + symmetric(&b.cov_upper[0]);
    let aa = symmetric(&a.cov_upper[1]) + symmetric(&b.cov_upper[1]);
    let mut cov = SMatrix::<f64, 6, 6>::zeros();
    cov.fixed_view_mut::<3, 3>(0, 0).copy_from(&(Zt * pp * Za));
    cov.fixed_view_mut::<3, 3>(3, 3).copy_from(&aa);
    let mut z = Vector6::zeros();
    z.fixed_rows_mut::<3>(0).copy_from(&v);
    z.fixed_rows_mut::<3>(3).copy_from(&w);
    Some((z, cov / (dt * dt)))
}

impl<const D: usize> Fuse<InsModel<D>> for PoseSample {
    fn fuse(&self, model: &InsModel<D>, s: &mut InsState<D>) -> (StepOutcome, Option<SVector<f64, D>>) {
        let frames = model.frames();
        // A pose sensor that is not configured has no frame.
        let Some(config) = super::settings::<PoseSample>(frames, self.header.sensor) else { return (StepOutcome::Refused, None) };
        let mount = frames.mount(SampleKind::Pose, self.header.sensor);
        if config.relative {
            // Disjoint pairs: a pose that ends a pair does not start the next.
            let this = previous(self);
            let Some((z, cov)) = model.progress_mut::<PoseSample>(s).last.take().and_then(|a| relative_twist(&a, &this)) else {
                model.progress_mut::<PoseSample>(s).last = Some(this);
                return (StepOutcome::Propagated, None);
            };
            if !nonholonomic::attitude_known(s) {
                return (StepOutcome::Refused, None);
            }
            let (h, H) = super::twist::twist(s, mount);
            let R = cov + super::twist::gyro_noise(model, s, mount);
            return model.update_residual_selected(s, &(z - h), &H, &R, &config.fuse.mask);
        }
        let estimated = config.configured_frame().is_none();
        if estimated {
            let Some(i) = s.aux_index(aux::POSE_FRAME_YAW) else { return (StepOutcome::Refused, None) };
            if s.aux_progress().kinds.pose.due(self.reset_counter, config.realign_after_gated) {
                let Ok(R) = selected_covariance(&self.cov, &config.fuse.mask) else { return (StepOutcome::Refused, None) };
                if !set_frame(s, mount, i, self, &R, &config.fuse.mask) {
                    return (StepOutcome::Refused, None);
                }
                model.progress_mut::<PoseSample>(s).aligned(self.reset_counter);
                return (StepOutcome::Propagated, None);
            }
        }
        let Some(o) = self.observe(model, s) else { return (StepOutcome::Refused, None) };
        let out = model.update_residual_selected(s, &o.y, &o.H, &o.R, &config.fuse.mask);
        if estimated {
            // The estimated frame's sensor: its run of gated poses.
            model.progress_mut::<PoseSample>(s).fused(matches!(out.0, StepOutcome::Gated { .. }));
        }
        out
    }
}

/// A pose in a map frame, configured or estimated: `y = [z_p − m̂; Log(Ŝᵀ Z)]`,
/// `H` of [`pose`], `R` the sample's; all six components (a sensor's
/// `[sensor.pose] fuse` selects among them when fused). `None` for a relative
/// sensor (the change between two poses is fused, as a twist), a sensor
/// without its table, and while the estimated frame is due to be set from
/// this sample.
impl<const D: usize> Observe<InsModel<D>, 6, D> for PoseSample {
    fn observe(&self, model: &InsModel<D>, s: &InsState<D>) -> Option<Observation<6, D>> {
        let frames = model.frames();
        let config = super::settings::<PoseSample>(frames, self.header.sensor).filter(|c| !c.relative)?;
        let frame = match config.configured_frame() {
            Some((yaw, origin)) => MapFrame { yaw, origin: Vector3::from(origin), states: None },
            None => {
                let i = s.aux_index(aux::POSE_FRAME_YAW)?;
                if s.aux_progress().kinds.pose.due(self.reset_counter, config.realign_after_gated) {
                    return None;
                }
                MapFrame::estimated_at(s, i)
            }
        };
        let (m, S, H) = pose(s, frames.mount(SampleKind::Pose, self.header.sensor), &frame);
        let mask = &config.fuse.mask;
        Some(Observation { y: residual(&m, &S, self, mask), H, R: selected_covariance(&self.cov, mask).ok()? })
    }
}

#[cfg(test)]
mod tests;
