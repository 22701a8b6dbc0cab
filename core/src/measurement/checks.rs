//! The checks every kind's module uses: its settings table read into its
//! type, and a sample's values finite and its covariance one.

use nalgebra::SMatrix;

use crate::setting::ConfigError;
use crate::validate::Rejection;

/// A kind's settings table as written (`[sensor.<table>]`), read into its type;
/// an error names the table (`key("")`) and says what is wrong in it.
pub fn read_table<T: serde::de::DeserializeOwned>(
    table: &toml::Value,
    key: &dyn Fn(&str) -> String,
) -> Result<T, ConfigError> {
    table.clone().try_into().map_err(|e: toml::de::Error| crate::setting::invalid(key(""), e.message()))
}

/// A kind's settings table as written, or its type's defaults without one
/// ([`read_table`]).
pub fn read_table_or_default<T: serde::de::DeserializeOwned + Default>(
    table: Option<&toml::Value>,
    key: &dyn Fn(&str) -> String,
) -> Result<T, ConfigError> {
    table.map_or_else(|| Ok(T::default()), |t| read_table(t, key))
}

/// Checks that every value is finite.
pub fn finite(values: &[f64]) -> Result<(), Rejection> {
    if values.iter().all(|v| v.is_finite()) { Ok(()) } else { Err(Rejection::NonFinite) }
}

/// Checks a 3×3 row-major covariance: finite, symmetric to 1e-9 of its largest
/// entry, with a Cholesky factor (positive definite).
pub fn covariance3(cov: &[f64; 9]) -> Result<(), Rejection> {
    covariance::<3>(cov)
}

/// Checks an `N`×`N` row-major covariance (`N²` values) as [`covariance3`].
pub fn covariance<const N: usize>(cov: &[f64]) -> Result<(), Rejection> {
    finite(cov)?;
    let c = SMatrix::<f64, N, N>::from_row_slice(cov);
    if (c - c.transpose()).amax() > SYMMETRY_TOLERANCE * c.amax() {
        return Err(Rejection::CovarianceNotSymmetric);
    }
    if nalgebra::Cholesky::new(c).is_none() {
        return Err(Rejection::CovarianceNotPositiveDefinite);
    }
    Ok(())
}

/// Relative tolerance of the symmetry check, against the largest entry.
pub(crate) const SYMMETRY_TOLERANCE: f64 = 1e-9;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bad_covariance_has_its_reason() {
        assert_eq!(covariance3(&[1.0, 0.1, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0, 2.0]), Ok(()));
        assert_eq!(covariance3(&[1.0, 0.5, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0, 2.0]), Err(Rejection::CovarianceNotSymmetric));
        assert_eq!(
            covariance3(&[1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 2.0]),
            Err(Rejection::CovarianceNotPositiveDefinite)
        );
        assert_eq!(covariance3(&[0.0; 9]), Err(Rejection::CovarianceNotPositiveDefinite));
        assert_eq!(covariance3(&[f64::NAN; 9]), Err(Rejection::NonFinite));
    }
}
