//! What a kind's fusion may change of an [`InsState`] besides a measurement
//! update ([`InsModel::update_residual`] and its kin): each a narrow
//! operation of the model, so that the state's fields stay the model's. The
//! others are the model's own functions of the same kind: setting auxiliary
//! states from a sample ([`aux::augment`](super::aux)) and turning the
//! heading alone ([`course::turn_heading`](super::course)).

use fusion_shared::sample::InKindsProgress;
use nalgebra::{Matrix3, UnitQuaternion};

use super::{InsModel, InsState};

impl<const D: usize> InsModel<D> {
    /// The bookkeeping kind `T` keeps in `s` between its samples (what its
    /// file declares, [`fusion_shared::sample::KindProgress`]; the state
    /// carries it, so a rewind restores it with the rest): that kind's and no
    /// other part of the state.
    #[inline]
    pub fn progress_mut<'s, T: InKindsProgress>(&self, s: &'s mut InsState<D>) -> &'s mut T::Progress {
        T::of_mut(&mut s.aux.kinds)
    }

    /// Sets the attitude to `q` and its error covariance to `block`,
    /// uncorrelated with the other states: an attitude set from a measurement
    /// of it (the attitude kind's alignment).
    #[inline]
    pub fn reset_attitude(&self, s: &mut InsState<D>, q: UnitQuaternion<f64>, block: &Matrix3<f64>) {
        s.reset_attitude(q, block);
    }

    /// Whether the sample being fused is due to reset what its kind observes
    /// (its run of gated samples is long enough: [`crate::model::lockout`]).
    #[inline]
    pub fn reset_due(&self, s: &InsState<D>) -> bool {
        s.kind_runs.due_now()
    }

    /// The sample's kind has made the reset its own way (a magnetometer turns
    /// the heading alone): its update is then an ordinary one, and the reset
    /// is counted when it is fused ([`KindRuns::handled`](crate::model::lockout::KindRuns::handled)).
    #[inline]
    pub fn reset_made(&self, s: &mut InsState<D>) {
        s.kind_runs.handled();
    }
}
