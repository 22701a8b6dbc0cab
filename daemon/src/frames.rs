//! The frames samples are given in besides the world frame: the datum of
//! geodetic fixes.
//!
//! The world frame is east-north-up about a datum. The datum is configured
//! (`[datum]`), or else it is the first valid geodetic fix the engine processes,
//! and once set it never changes for the rest of the run: every estimate and
//! snapshot is in the same frame, and `fusiond replay` of the same arrival order
//! picks the same datum as the live daemon did.

use std::cell::OnceCell;

use fusion_shared::geodesy::Datum;

/// The datum of the world frame, set once.
#[derive(Debug, Clone, Default)]
pub struct Frames {
    datum: OnceCell<Datum>,
}

impl Frames {
    /// Frames with the configured datum, or none yet (the first geodetic fix's).
    pub fn new(datum: Option<Datum>) -> Self {
        let cell = OnceCell::new();
        if let Some(d) = datum {
            let _ = cell.set(d);
        }
        Self { datum: cell }
    }

    /// The datum, once there is one.
    pub fn datum(&self) -> Option<&Datum> {
        self.datum.get()
    }

    /// The datum, set to `first` if there was none.
    pub fn datum_or_set(&self, first: Datum) -> &Datum {
        self.datum.get_or_init(|| first)
    }
}
