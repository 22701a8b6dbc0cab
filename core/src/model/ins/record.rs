//! The smoother's record of an `ins` step and its log while the step runs
//! (see `Model::begin_record`, `Model::finish_record`).

use nalgebra::SVector;

use super::{N, NOMINAL_MAX};
use crate::filter::{RtsStep, StepLog};
#[cfg(doc)]
use crate::model::Model;

/// The smoother's record of one `ins` step (see [`Model::finish_record`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InsRecord<const D: usize = N> {
    /// The error-state step, about the nominal state after it.
    pub step: RtsStep<f64, D>,
    /// Nominal state after the step (after smoothing: the smoothed nominal
    /// state); its first `D + 1` entries are used.
    pub nominal: [f64; NOMINAL_MAX],
}

/// The smoother's log of one `ins` step while it runs: the filter's, and how
/// many times auxiliary states had been set from a sample when it began.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InsLog<const D: usize = N> {
    pub(super) step: StepLog<f64, D>,
    pub(super) sets: u32,
}

/// The whole change of the nominal state by two corrections of one step (a
/// heading turned, then an update injected): what the smoother's record holds.
pub fn both<const D: usize>(first: Option<SVector<f64, D>>, then: Option<SVector<f64, D>>) -> Option<SVector<f64, D>> {
    match (first, then) {
        (Some(a), Some(b)) => Some(a + b),
        (a, b) => a.or(b),
    }
}
