//! Pure estimation math on fixed-size nalgebra types: no IO, no IPC, no allocation.
//!
//! - [`kalman`]: the filter: predict, update, in the Joseph or the UDU form.
//! - [`udu`]: the UDU factors: Thornton's predict, Bierman's update.
//! - [`measurement`]: update decisions, diagnostics, the fault-detection hook.
//! - [`gate`]: chi-square NIS gate.
//! - [`smoother`]: Rauch–Tung–Striebel smoother over a logged history.
//! - [`discretize`]: `exp(A T)`, Van Loan, forward-Euler input.

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
