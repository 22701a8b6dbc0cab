//! The odometry scale factor as a state of the `ins` model
//! (`[model.odometry_scale]`): its parameters (the state is one of the
//! auxiliary states, [`super::aux`]). The measurement that uses it is the odometry
//! kind's, in the layer above.

/// `[model.odometry_scale]`: the odometry scale factor `k` as a state
/// (odometry speed = `k` × true speed, one factor for every odometry sensor).
///
/// Tyre wear, pressure and load change the rolling radius: a scale error of
/// 0.5–2 % is normal, and unestimated it makes odometry pull the position along
/// the track by that share of the distance driven (Groves 2013, §16.2.1). The
/// state is a random walk, `k̇ = n_k` with density `random_walk`; it is learned
/// while GNSS fixes show the speed and carried through an outage.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometryScale {
    /// `k` at start (default 1).
    #[serde(default = "OdometryScale::default_initial")]
    pub initial: f64,
    /// Its standard deviation at start (default 0.02, a 2 % scale error).
    #[serde(default = "OdometryScale::default_initial_std")]
    pub initial_std: f64,
    /// Random-walk density of `k`, 1/√s (default 10⁻⁵: 0.06 % in an hour).
    #[serde(default = "OdometryScale::default_random_walk")]
    pub random_walk: f64,
}

impl OdometryScale {
    fn default_initial() -> f64 {
        1.0
    }
    fn default_initial_std() -> f64 {
        0.02
    }
    fn default_random_walk() -> f64 {
        1e-5
    }
}

impl Default for OdometryScale {
    fn default() -> Self {
        Self {
            initial: Self::default_initial(),
            initial_std: Self::default_initial_std(),
            random_walk: Self::default_random_walk(),
        }
    }
}
