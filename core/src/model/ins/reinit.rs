//! Lock-out recovery of the `ins` model ([`crate::model::lockout`]).

#![allow(non_snake_case)]

use nalgebra::{Matrix3, Vector3};

use super::{InsModel, InsState};
use crate::model::StepOutcome;
use crate::model::lockout::LockoutConfig;

impl<const D: usize> InsModel<D> {
    /// The same model with lock-out recovery.
    pub fn with_lockout(mut self, lockout: Option<LockoutConfig>) -> Self {
        self.lockout = lockout;
        self
    }

    /// Lock-out recovery, if configured.
    pub fn lockout(&self) -> Option<&LockoutConfig> {
        self.lockout.as_ref()
    }

    /// Takes the outcome of a position fix, `origin` being the fix taken to the
    /// body origin, and re-initialises after a lock-out: nominal `p`, `v` from
    /// the fixes, attitude and biases held; the error covariance of
    /// [`Reinit::covariance`](crate::model::lockout::Reinit::covariance).
    pub(crate) fn observe_fix(
        &self,
        s: &mut InsState<D>,
        outcome: &StepOutcome,
        origin: &Vector3<f64>,
        R: &Matrix3<f64>,
    ) {
        let t = s.t_ns.unwrap_or(0);
        let Some(r) = s.lockout.observe(self.lockout.as_ref(), outcome, t, origin, R) else { return };
        let P = r.covariance(&self.initial.P());
        let (q, b_a, b_g) = (s.q(), s.b_a(), s.b_g());
        s.put(r.p, r.v, q, b_a, b_g);
        s.kf.reset_error(|old| *old = P);
    }
}
