//! `fuse = [...]`: the components of a six-component sample (a twist, a pose)
//! a sensor fuses, by name.

use std::marker::PhantomData;

use serde::Deserialize;

/// The names of a kind's six components, in its sample's order.
pub trait ComponentNames {
    /// The names, as `fuse = [...]` spells them.
    const NAMES: [&'static str; 6];
}

/// `fuse = [...]`: which of a sample's six components are fused
/// (robot_localization's `odom0_config`); the others are left out of the
/// update, their correlations with the fused ones dropped (the marginal of the
/// fused ones), and the gate and the health count only the fused ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Components<N> {
    /// Whether each component is fused.
    pub mask: [bool; 6],
    names: PhantomData<N>,
}

impl<N> Default for Components<N> {
    /// All six.
    fn default() -> Self {
        Self { mask: [true; 6], names: PhantomData }
    }
}

impl<N> Components<N> {
    /// How many are fused.
    pub fn count(&self) -> usize {
        self.mask.iter().filter(|m| **m).count()
    }

    /// Whether all six are.
    pub fn all(&self) -> bool {
        self.count() == 6
    }
}

impl<'de, N: ComponentNames> Deserialize<'de> for Components<N> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let names = Vec::<String>::deserialize(d)?;
        let mut mask = [false; 6];
        for name in &names {
            let Some(i) = N::NAMES.iter().position(|n| n == name) else {
                return Err(serde::de::Error::custom(format!(
                    "unknown component {name:?}; the components are {}",
                    N::NAMES.join(", ")
                )));
            };
            mask[i] = true;
        }
        if !mask.contains(&true) {
            return Err(serde::de::Error::custom(format!(
                "selects no component; the components are {}",
                N::NAMES.join(", ")
            )));
        }
        Ok(Self { mask, names: PhantomData })
    }
}

/// The smallest variance of a fused component, in its own unit squared (m²,
/// (m/s)², rad², (rad/s)²): a selected component's variance below it, 0 among
/// them (drivers send 0 for "not measured" or "exact"), is taken as this, as
/// robot_localization floors a measurement's variances (1e-9, its `Ekf::correct`).
/// An exact reading would make the update's innovation covariance as small as
/// the prior's part of it, and with a prior as small, not invertible.
pub const VARIANCE_FLOOR: f64 = 1e-9;

/// The covariance a sample of `N` components is fused with when `mask`
/// selects among them (`cov` row-major `N`×`N`): the selected block of `cov`,
/// each of its variances below [`VARIANCE_FLOOR`] (≥ 0) floored to it; the
/// rows and columns of the components not selected zero, with a unit
/// variance, so that nothing of them (a NaN, a zero, garbage) is looked at.
/// Checked as [`super::covariance`] checks a whole one: finite, symmetric,
/// positive definite (a negative variance is refused, never floored).
///
/// Math note: the marginal of the selected components of a Gaussian is the
/// selected block of its covariance; floored, it is that block plus a
/// non-negative diagonal.
pub fn selected_covariance<const N: usize>(
    cov: &[f64],
    mask: &[bool; N],
) -> Result<nalgebra::SMatrix<f64, N, N>, super::Rejection> {
    use super::Rejection;
    let mut c = nalgebra::SMatrix::<f64, N, N>::identity();
    for i in (0..N).filter(|&i| mask[i]) {
        for j in (0..N).filter(|&j| mask[j]) {
            let v = cov[i * N + j];
            if !v.is_finite() {
                return Err(Rejection::NonFinite);
            }
            c[(i, j)] = if i == j && (0.0..VARIANCE_FLOOR).contains(&v) { VARIANCE_FLOOR } else { v };
        }
    }
    if (c - c.transpose()).amax() > super::SYMMETRY_TOLERANCE * c.amax() {
        return Err(Rejection::CovarianceNotSymmetric);
    }
    if nalgebra::Cholesky::new(c).is_none() {
        return Err(Rejection::CovarianceNotPositiveDefinite);
    }
    Ok(c)
}

/// Whether every selected one of six values (three then three) is finite.
pub fn selected_finite(first: &[f64; 3], second: &[f64; 3], mask: &[bool; 6]) -> Result<(), super::Rejection> {
    let finite = first.iter().chain(second).zip(mask).all(|(v, keep)| !keep || v.is_finite());
    if finite { Ok(()) } else { Err(super::Rejection::NonFinite) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measurement::Rejection;

    /// What is not selected is never looked at; a selected zero variance is
    /// floored; a selected negative one is refused.
    #[test]
    fn only_the_selected_block_is_checked_and_a_zero_variance_is_floored() {
        let mask = [true, true, false, false, false, true];
        let mut cov = [0.0; 36];
        (cov[0], cov[7], cov[35]) = (0.04, 0.0, 0.01);
        // Garbage where nothing is selected: NaN, a negative variance, asymmetry.
        (cov[14], cov[21], cov[2], cov[13]) = (f64::NAN, -1.0, 5.0, -3.0);
        let c = selected_covariance(&cov, &mask).unwrap();
        assert_eq!((c[(0, 0)], c[(1, 1)], c[(5, 5)]), (0.04, VARIANCE_FLOOR, 0.01));
        assert_eq!((c[(2, 2)], c[(2, 0)], c[(0, 2)]), (1.0, 0.0, 0.0));
        let mut other = cov;
        (other[14], other[21], other[2]) = (7.0, 2.0, 0.5);
        assert_eq!(selected_covariance(&other, &mask), Ok(c), "the unselected entries are never read");
        cov[35] = -0.01;
        assert_eq!(selected_covariance(&cov, &mask), Err(Rejection::CovarianceNotPositiveDefinite));
        cov[35] = f64::NAN;
        assert_eq!(selected_covariance(&cov, &mask), Err(Rejection::NonFinite));
        assert_eq!(selected_finite(&[1.0, 2.0, f64::NAN], &[0.0; 3], &mask), Ok(()));
        assert_eq!(selected_finite(&[1.0, f64::NAN, 0.0], &[0.0; 3], &mask), Err(Rejection::NonFinite));
    }
}
