//! What a pose sensor keeps between its samples, in the filter state (its
//! kind's [`KindProgress`](crate::sample::KindProgress); a
//! rewind restores it with the rest): where its estimated map frame stands, and
//! a relative sensor's last pose.

/// A pose kept for the next one of a relative pose sensor (its change is
/// fused by the pose measurement): what the difference needs, compactly (it is
/// part of every filter state the engine keeps).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreviousPose {
    /// Its time, ns.
    pub t_ns: u64,
    /// Its sensor.
    pub sensor: u32,
    /// Its re-initialisation counter.
    pub reset_counter: u32,
    /// Position, m, map frame.
    pub position: [f64; 3],
    /// Rotation, sensor → map, `[w, x, y, z]`.
    pub orientation_wxyz: [f64; 4],
    /// The upper triangles (row by row) of its position and attitude
    /// covariance blocks.
    pub cov_upper: [[f64; 6]; 2],
}

/// Where a pose sensor's estimated map frame stands.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PoseProgress {
    /// The frame has been set, from a pose with this re-initialisation counter.
    pub counter: Option<u32>,
    /// Consecutive poses gated since the last fused one.
    pub gated: u32,
    /// Times the frame was set (the first, and every re-initialisation).
    pub alignments: u32,
    /// The last pose of a relative pose sensor.
    pub last: Option<PreviousPose>,
}

impl PoseProgress {
    /// Whether a pose with `reset_counter` sets the frame (again): the first
    /// pose, the localiser re-initialised (a new counter), or `realign_after`
    /// gated poses in a row (> 0: it re-initialised without saying so).
    pub fn due(&self, reset_counter: u32, realign_after: u32) -> bool {
        self.counter != Some(reset_counter) || (realign_after > 0 && self.gated >= realign_after)
    }

    /// The frame was set from a pose with `reset_counter`.
    pub fn aligned(&mut self, reset_counter: u32) {
        self.counter = Some(reset_counter);
        self.gated = 0;
        self.alignments += 1;
    }

    /// A pose was fused (`gated` false) or gated against the frame.
    pub fn fused(&mut self, gated: bool) {
        self.gated = if gated { self.gated + 1 } else { 0 };
    }
}
