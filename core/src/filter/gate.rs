//! Innovation gating by the normalised innovation squared (NIS).
//!
//! Under a consistent filter `NIS = yᵀ S⁻¹ y ~ χ²ₘ` with `m` the measurement
//! dimension (Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to
//! Tracking and Navigation*, 2001, §5.4.2 and §7.4.2). A measurement whose NIS
//! exceeds the χ²ₘ quantile at probability `p` is an outlier at level `1 − p`.

use statrs::distribution::{ChiSquared, ContinuousCDF};

/// Largest measurement dimension the gate has a threshold for.
pub const MAX_GATE_DIMS: usize = 16;

/// Why a gate could not be built.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum GateError {
    /// The probability must lie strictly between 0 and 1.
    #[error("gating probability must be in (0, 1), got {0}")]
    Probability(f64),
}

/// Dimension-aware chi-square gate: threshold `γₘ = F⁻¹_χ²ₘ(p)` for `m = 1..=16`,
/// computed once at construction (no work on the hot path).
#[derive(Debug, Clone, PartialEq)]
pub struct ChiSquareGate {
    probability: f64,
    thresholds: [f64; MAX_GATE_DIMS + 1],
}

impl ChiSquareGate {
    /// Builds the gate for probability `p` (e.g. 0.999: 1 in 1000 good
    /// measurements is refused).
    pub fn new(p: f64) -> Result<Self, GateError> {
        if !(p > 0.0 && p < 1.0) {
            return Err(GateError::Probability(p));
        }
        let mut thresholds = [f64::INFINITY; MAX_GATE_DIMS + 1];
        for (m, th) in thresholds.iter_mut().enumerate().skip(1) {
            // `m ≥ 1` so the distribution exists.
            let chi2 = ChiSquared::new(m as f64).map_err(|_| GateError::Probability(p))?;
            *th = chi2.inverse_cdf(p);
        }
        Ok(Self { probability: p, thresholds })
    }

    /// The probability the gate was built for.
    pub fn probability(&self) -> f64 {
        self.probability
    }

    /// The NIS threshold for `m` degrees of freedom; `∞` (nothing gated) for
    /// `m = 0` or `m` above [`MAX_GATE_DIMS`].
    pub fn threshold(&self, m: usize) -> f64 {
        self.thresholds.get(m).copied().unwrap_or(f64::INFINITY)
    }

    /// True if a measurement with this NIS and dimension passes the gate.
    pub fn accepts(&self, nis: f64, m: usize) -> bool {
        nis <= self.threshold(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thresholds_match_chi_square_tables() {
        // Reference quantiles (e.g. NIST/SEMATECH e-Handbook, Table 1.3.6.7.4).
        let g = ChiSquareGate::new(0.99).unwrap();
        assert!((g.threshold(1) - 6.634896601).abs() < 1e-6);
        assert!((g.threshold(2) - 9.210340372).abs() < 1e-6);
        assert!((g.threshold(3) - 11.34486673).abs() < 1e-6);
        let g = ChiSquareGate::new(0.999).unwrap();
        assert!((g.threshold(1) - 10.82756617).abs() < 1e-6);
        // m = 2 has the closed form −2 ln(1 − p).
        assert!((g.threshold(2) - (-2.0 * (0.001f64).ln())).abs() < 1e-9);
        assert!((g.threshold(3) - 16.26623620).abs() < 1e-6);
        let g = ChiSquareGate::new(0.95).unwrap();
        assert!((g.threshold(1) - 3.841458821).abs() < 1e-6);
        assert!((g.threshold(3) - 7.814727903).abs() < 1e-6);
    }

    #[test]
    fn gate_decides_by_dimension() {
        let g = ChiSquareGate::new(0.99).unwrap();
        assert!(!g.accepts(7.0, 1));
        assert!(g.accepts(7.0, 2));
        assert!(g.accepts(1e9, 0));
    }

    #[test]
    fn bad_probability_is_an_error() {
        for p in [0.0, 1.0, -0.5, f64::NAN] {
            assert!(ChiSquareGate::new(p).is_err());
        }
    }
}
