//! Pure estimation math on fixed-size nalgebra types: no IO, no IPC, no allocation.
//!
//! - [`kalman`]: the filter: predict, update, in the Joseph or the UDU form.
//! - [`udu`]: the UDU factors: Thornton's predict, Bierman's update.
//! - [`measurement`]: update decisions, diagnostics, the fault-detection hook.
//! - [`gate`]: chi-square NIS gate.
//! - [`smoother`]: Rauch–Tung–Striebel smoother over a logged history.
//! - [`discretize`]: `exp(A T)`, Van Loan, forward-Euler input.
//! - [`wrap_angle`]: an angle into (−π, π].

pub mod discretize;
pub mod gate;
pub mod kalman;
pub mod measurement;
pub mod smoother;
pub mod udu;

pub use gate::ChiSquareGate;
pub use kalman::{
    FaultDecision, FaultDetector, FilterError, Form, KalmanFilter, MeasurementView, UpdateDecision, UpdateDiagnostics,
    UpdateOptions, map_process_noise,
};
pub use smoother::{RtsStep, StepLog, rts_smooth};

/// An angle wrapped into (−π, π], rad.
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::PI;
    let w = a.rem_euclid(2.0 * PI); // [0, 2π)
    if w > PI { w - 2.0 * PI } else { w }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    #[test]
    fn angles_wrap_into_minus_pi_exclusive_to_pi() {
        assert_eq!(super::wrap_angle(PI), PI);
        assert_eq!(super::wrap_angle(-PI), PI);
        assert!((super::wrap_angle(1.5 * PI) + 0.5 * PI).abs() < 1e-15);
        assert!((super::wrap_angle(-2.5 * PI) + 0.5 * PI).abs() < 1e-15);
        assert_eq!(super::wrap_angle(0.25), 0.25);
    }
}
