//! Pure estimation math on fixed-size nalgebra types: no IO, no IPC, no allocation.
//!
//! - [`kalman`]: the filter: predict, Joseph-form update.
//! - [`measurement`]: update decisions, diagnostics, the fault-detection hook.
//! - [`gate`]: chi-square NIS gate.
//! - [`smoother`]: Rauch–Tung–Striebel smoother over a logged history.
//! - [`discretize`]: `exp(A T)`, Van Loan, forward-Euler input.

pub mod discretize;
pub mod gate;
pub mod kalman;
pub mod measurement;
pub mod smoother;

pub use gate::ChiSquareGate;
pub use kalman::{
    FaultDecision, FaultDetector, FilterError, KalmanFilter, MeasurementView, UpdateDecision, UpdateDiagnostics,
    UpdateOptions, map_process_noise,
};
pub use smoother::{RtsStep, SmootherError, StepLog, rts_smooth};
